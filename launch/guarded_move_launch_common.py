"""Shared builder of the tactile_force launch files (guarded_move, joystick).

The nodes, their parameter files and overrides come from
tactile_force_nodes.nodes(), which the tests over DDS use too. The robot:
`robot:=pa10|ur5|panda` (config/<robot>.urdf and config/<robot>.yaml), or
`urdf:=FILE` with `base_link:=` and `tip_link:=` (empty: the URDF's root
and its one leaf); the URDF goes to sim_robot and force_controller as their
`robot_description` parameter, or, with `description_topic:=true`, they
take it from /robot_description (a robot_state_publisher's). `rviz:=true`
adds RViz on config/tactile_force.rviz (and, in simulation, a
robot_state_publisher for the arm's TF): tactile_force_nodes.viewers().
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from tactile_force_nodes import ROBOTS, nodes, viewers

SCENE = "guarded_move.yaml"


def make(scene=SCENE):
    def setup(context):
        value = lambda name: context.launch_configurations[name]  # noqa: E731
        config = os.path.join(FindPackageShare("tactile_force").perform(context), "config")
        urdf = value("urdf")
        robot = None if urdf else value("robot")
        if robot is not None and robot not in ROBOTS:
            raise RuntimeError(f"robot:={robot}: expected one of {', '.join(ROBOTS)}, or urdf:=FILE")
        path = urdf or os.path.join(config, f"{robot}.urdf")
        with open(path) as f:
            text = f.read()
        description = None if value("description_topic") == "true" else text
        links = (value("base_link"), value("tip_link")) if urdf else None
        args = dict(
            object_name=value("object"),
            model=value("model"),
            port=value("port"),
            sim_time=value("use_sim_time") == "true",
            real_time_factor=float(value("real_time_factor")),
            robot=robot,
            description=description,
            links=links,
            biotac_frame=value("biotac_frame"),
            start_state=value("start_state"),
        )
        use_sim = value("use_sim") == "true"
        started = nodes(scene, use_sim, **args)
        ours = [
            Node(
                package="tactile_force",
                executable=executable,
                name=executable,
                output="screen",
                parameters=[os.path.join(config, name) for name in files] + [overrides],
                # Its enclave of config/sros2/tactile_force.policy.xml (read
                # only with ROS_SECURITY_ENABLE=true).
                ros_arguments=["--enclave", f"/tactile_force/{executable}"],
            )
            for executable, files, overrides in started
        ]
        if value("rviz") != "true":
            return ours
        shown = viewers(config, text, base_link=value("base_link") if urdf else "",
                        state_publisher=use_sim and description is not None, sim_time=args["sim_time"])
        return ours + [
            Node(package=package, executable=executable, output="screen", arguments=arguments,
                 parameters=[parameters])
            for package, executable, arguments, parameters in shown
        ]

    return LaunchDescription([
        DeclareLaunchArgument("use_sim", default_value="true",
                              description="Simulated arm, object and BioTac (no hardware)."),
        DeclareLaunchArgument("robot", default_value="pa10",
                              description=f"A shipped robot: {', '.join(ROBOTS)} (config/<robot>.urdf, .yaml)."),
        DeclareLaunchArgument("urdf", default_value="",
                              description="A URDF file of your robot instead (with base_link, tip_link)."),
        DeclareLaunchArgument("base_link", default_value="",
                              description="With urdf:=FILE: first link of the chain; empty: the root."),
        DeclareLaunchArgument("tip_link", default_value="",
                              description="With urdf:=FILE: the link the BioTac is on; empty: the one leaf."),
        DeclareLaunchArgument("description_topic", default_value="false",
                              description="Take the URDF from /robot_description, not the file."),
        DeclareLaunchArgument("biotac_frame", default_value="biotac",
                              description="The BioTac frame: the wrenches' frame_id, on /tf_static in the tip link."),
        DeclareLaunchArgument("start_state", default_value="active",
                              description="Where force_controller and biotac_driver (managed nodes) go at start: "
                                          "active, inactive (then `ros2 lifecycle set NODE activate`) or unconfigured."),
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
        DeclareLaunchArgument("rviz", default_value="false",
                              description="Also RViz on config/tactile_force.rviz (the arm, the BioTac frame, "
                                          "the wrench, its 1-sigma and the phase); in simulation with a "
                                          "robot_state_publisher for the arm's TF."),
        OpaqueFunction(function=setup),
    ])
