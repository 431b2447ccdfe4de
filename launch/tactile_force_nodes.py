"""The nodes the tactile_force launch files start, as plain data.

The launch files (guarded_move.launch.py, joystick.launch.py) and the tests
over DDS (tests/ros/) both build their processes from `nodes()`, so the node
list, parameter files and overrides cannot drift apart. No ROS import here.
"""


def param_files(scene):
    """Parameter files, in config/, layered in this order (later wins)."""
    return ["pa10.yaml", "world.yaml", scene, "ros2.yaml"]


def nodes(scene, use_sim, object_name, model, port, sim_time=False, real_time_factor=1.0):
    """(executable, parameter files, overrides) for each node to start.

    scene: guarded_move.yaml or guided_move.yaml; use_sim: the simulated arm
    and BioTac (sim_robot) rather than the serial driver; object_name, model,
    port: the launch arguments; sim_time: every node on sim_robot's /clock,
    which runs real_time_factor times faster than the wall clock (values, or
    launch substitutions).
    """
    files = param_files(scene)
    # Passed to every node, as Scene::with_object does in the embedded runtime.
    shared = {"object": object_name, "use_sim_time": sim_time}
    sim = ("sim_robot", files, dict(shared, real_time_factor=real_time_factor))
    first = sim if use_sim else ("biotac_driver", [], dict(shared, port=port))
    return [
        first,
        ("wrench_estimator", files, dict(shared, model_file=model)),
        ("force_controller", files, shared),
    ]
