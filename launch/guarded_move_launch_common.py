"""Shared builder of the tactile_force launch files (guarded_move, joystick).

The nodes, their parameter files and overrides come from
tactile_force_nodes.nodes(), which the tests over DDS use too.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from tactile_force_nodes import nodes

SCENE = "guarded_move.yaml"


def make(scene=SCENE):
    config = PathJoinSubstitution([FindPackageShare("tactile_force"), "config"])
    use_sim = LaunchConfiguration("use_sim")
    args = dict(
        object_name=LaunchConfiguration("object"),
        model=LaunchConfiguration("model"),
        port=LaunchConfiguration("port"),
        sim_time=ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool),
        real_time_factor=ParameterValue(LaunchConfiguration("real_time_factor"), value_type=float),
    )

    def node(executable, files, overrides, condition=None):
        params = [PathJoinSubstitution([config, name]) for name in files] + [overrides]
        return Node(
            package="tactile_force",
            executable=executable,
            name=executable,
            output="screen",
            parameters=params,
            condition=condition,
        )

    sim = nodes(scene, True, **args)
    real = nodes(scene, False, **args)
    started = [node(*sim[0], condition=IfCondition(use_sim)),
               node(*real[0], condition=UnlessCondition(use_sim))]
    started += [node(*n) for n in sim[1:]]
    return LaunchDescription([
        DeclareLaunchArgument("use_sim", default_value="true",
                              description="Simulated arm, object and BioTac (no hardware)."),
        DeclareLaunchArgument("model", default_value="",
                              description="GP model file; empty: the default model."),
        DeclareLaunchArgument("port", default_value="/dev/ttyACM0",
                              description="Serial device of the BioTac bridge (use_sim:=false)."),
        DeclareLaunchArgument("use_sim_time", default_value="false",
                              description="Every node on sim_robot's /clock (use_sim:=true)."),
        DeclareLaunchArgument("real_time_factor", default_value="1.0",
                              description="Simulated seconds per wall-clock second (use_sim_time:=true), >= 1."),
        DeclareLaunchArgument("object", default_value="wooden_box" if scene == SCENE else "fingertip",
                              description="Object (config/world.yaml objects)."),
        *started,
    ])
