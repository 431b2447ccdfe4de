"""The nodes the tactile_force launch files start, as plain data.

The launch files (guarded_move.launch.py, joystick.launch.py) and the tests
over DDS (tests/ros/) both build their processes from `nodes()` (and, with
`rviz:=true`, `viewers()`), so the node list, parameter files and overrides
cannot drift apart. No ROS import here.
"""

import os
import xml.etree.ElementTree as ET

# The shipped robots: config/<name>.urdf and config/<name>.yaml.
ROBOTS = ("pa10", "ur5", "panda")
# The RViz configuration in config/ that `rviz:=true` opens.
RVIZ_CONFIG = "tactile_force.rviz"


def param_files(scene, robot="pa10"):
    """Parameter files, in config/, layered in this order (later wins): the
    world (every robot's defaults), the shipped robot's file (none for a
    URDF of the user's: robot=None), the scene."""
    if robot is not None and robot not in ROBOTS:
        raise ValueError(f"robot {robot!r}: expected one of {', '.join(ROBOTS)} or a URDF file")
    robot_file = [] if robot is None else [f"{robot}.yaml"]
    return ["world.yaml"] + robot_file + [scene]


def nodes(scene, use_sim, object_name, model, port, sim_time=False, real_time_factor=1.0,
          robot="pa10", description=None, links=None, biotac_frame="biotac", start_state="active"):
    """(executable, parameter files, overrides) for each node to start.

    scene: guarded_move.yaml or guided_move.yaml; use_sim: the simulated arm
    and BioTac (sim_robot) rather than the serial driver; object_name, model,
    port: the launch arguments; sim_time: every node on sim_robot's /clock,
    which runs real_time_factor times faster than the wall clock. robot: a
    shipped robot's name, or None for a URDF of the user's; description: the
    URDF text given to sim_robot and force_controller as their
    `robot_description` parameter, or None: they take it from the
    /robot_description topic; links: (base_link, tip_link) of the chain, or
    None for the robot file's (a URDF of the user's: its root and its one
    leaf); biotac_frame: the BioTac frame, the estimator's `frame_id` (the
    wrenches' frame) and the frame force_controller places on /tf_static;
    start_state: where the managed nodes (force_controller, biotac_driver)
    go at start, active by default, inactive or unconfigured to be brought
    up with `ros2 lifecycle set`.
    """
    files = param_files(scene, robot)
    # Passed to every node, as Scene::with_object does in the embedded runtime.
    shared = {"object": object_name, "use_sim_time": sim_time}
    arm = dict(shared)
    if description is not None:
        arm["robot_description"] = description
    if links is not None:
        arm["robot.base_link"], arm["robot.tip_link"] = links
    sim = ("sim_robot", files, dict(arm, real_time_factor=real_time_factor))
    first = sim if use_sim else ("biotac_driver", [], dict(shared, port=port, start_state=start_state))
    # In simulation the task starts at once; on a real arm the controller
    # commands zero until a goal, or a set of its `task`, asks for motion.
    return [
        first,
        ("wrench_estimator", files, dict(shared, model_file=model, frame_id=biotac_frame)),
        ("force_controller", files, dict(arm, autostart=use_sim, biotac_frame=biotac_frame,
                                         start_state=start_state)),
    ]


def urdf_root(description):
    """The root link of a URDF's text: the link no joint has as child (the
    robot's own joints: those of <transmission> or <ros2_control> name no
    links)."""
    robot = ET.fromstring(description)
    children = {j.find("child").get("link") for j in robot.findall("joint")}
    roots = [link.get("name") for link in robot.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise ValueError(f"the URDF has {len(roots)} root links ({', '.join(roots)}), not one")
    return roots[0]


def viewers(config_dir, description, base_link="", state_publisher=True, sim_time=False):
    """(package, executable, arguments, parameters) of each process that
    `rviz:=true` adds: rviz2 on config/tactile_force.rviz, its fixed frame
    the chain's base link (`base_link`, or else the URDF's root, from
    `description`, the URDF text); with `state_publisher` (the launch
    files: in simulation, the URDF from a file) also robot_state_publisher
    on that URDF, which publishes the arm's links on TF from sim_robot's
    joint_states and the description on /robot_description for RViz. On a
    real arm, or with `description_topic:=true`, your
    robot_state_publisher does both."""
    fixed = base_link or urdf_root(description)
    shared = {"use_sim_time": sim_time}
    rviz = ("rviz2", "rviz2", ["-d", os.path.join(config_dir, RVIZ_CONFIG), "-f", fixed], shared)
    if not state_publisher:
        return [rviz]
    state = ("robot_state_publisher", "robot_state_publisher", [], dict(shared, robot_description=description))
    return [state, rviz]
