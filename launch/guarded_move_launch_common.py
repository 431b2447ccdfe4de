"""Shared builder of the tactile_force launch files (guarded_move, joystick)."""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

SCENE = "guarded_move.yaml"


def make(scene=SCENE):
    config = PathJoinSubstitution([FindPackageShare("tactile_force"), "config"])
    files = [PathJoinSubstitution([config, name]) for name in ("pa10.yaml", "world.yaml", scene)]
    use_sim = LaunchConfiguration("use_sim")
    # Passed to every node, as Scene::with_object does in the embedded runtime.
    overrides = {"object": LaunchConfiguration("object")}

    def node(executable, params, **kw):
        return Node(
            package="tactile_force",
            executable=executable,
            name=executable,
            output="screen",
            parameters=params,
            **kw,
        )

    return LaunchDescription([
        DeclareLaunchArgument("use_sim", default_value="true",
                              description="Simulated arm, object and BioTac (no hardware)."),
        DeclareLaunchArgument("model", default_value="",
                              description="GP model file; empty: the default model."),
        DeclareLaunchArgument("port", default_value="/dev/ttyACM0",
                              description="Serial device of the BioTac bridge (use_sim:=false)."),
        DeclareLaunchArgument("object", default_value="wooden_box" if scene == SCENE else "fingertip",
                              description="Object (config/world.yaml objects)."),
        node("biotac_driver", [{"port": LaunchConfiguration("port")}, overrides],
             condition=UnlessCondition(use_sim)),
        node("sim_robot", files + [overrides], condition=IfCondition(use_sim)),
        node("wrench_estimator", files + [{"model_file": LaunchConfiguration("model")}, overrides]),
        node("force_controller", files + [overrides]),
    ])
