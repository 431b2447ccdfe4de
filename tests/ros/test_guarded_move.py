"""The guarded move over DDS: our executables as separate processes, started
with the launch files' node list (launch/tactile_force_nodes.py) and an
independent rclpy peer that checks, from the topics and the action:

- the move started at launch touches the wooden box and holds 1 N, measured
  on ft_sensor/wrench: overshoot <= 0.1 N, steady-state error <= 0.05 N over
  the last second, standard deviation <= 0.02 N over the last 2 s;
- a GuardedMove goal with the parameters' values ends with `hold`;
- a goal at 0.2 m/s, past the safety envelope, is aborted with a reason that
  names the limit.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import rclpy
from rclpy.action import ActionClient
from rclpy.qos import qos_profile_sensor_data
from geometry_msgs.msg import WrenchStamped
from action_msgs.msg import GoalStatus
from tactile_force_msgs.action import GuardedMove

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(REPO, "launch"))
from tactile_force_nodes import nodes  # noqa: E402

RESULTS = []


def check(name, ok, detail):
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}", flush=True)


def start_nodes(scene, object_name, logs):
    """Starts the nodes of `scene` as the launch file does; returns the processes."""
    procs = []
    for exe, files, overrides in nodes(scene, True, object_name, "", ""):
        # Overrides in a parameter file, as launch_ros passes them (an empty
        # string survives this way; `-p model_file:=` does not).
        extra = os.path.join(logs, f"{exe}_overrides.yaml")
        with open(extra, "w") as f:
            f.write(f"{exe}:\n  ros__parameters:\n")
            for k, v in overrides.items():
                f.write(f"    {k}: \"{v}\"\n")
        cmd = [exe, "--ros-args", "-r", f"__node:={exe}"]
        for name in files:
            cmd += ["--params-file", os.path.join(REPO, "config", name)]
        cmd += ["--params-file", extra]
        log = open(os.path.join(logs, f"{exe}.log"), "w")
        procs.append(subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=REPO))
    return procs


def spin_for(node, seconds, until=None):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
        if until is not None and until():
            return True
    return until is None


def send_goal(node, client, goal, timeout):
    future = client.send_goal_async(goal)
    if not spin_for(node, 10, future.done):
        return None, "no answer to the goal"
    handle = future.result()
    if not handle.accepted:
        return None, "goal rejected"
    result = handle.get_result_async()
    if not spin_for(node, timeout, result.done):
        return None, f"no result within {timeout} s"
    return result.result(), ""


def main():
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(10, 200))
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    logs = tempfile.mkdtemp(prefix="tactile_force_ros_")
    procs = start_nodes("guarded_move.yaml", "wooden_box", logs)
    rclpy.init()
    node = rclpy.create_node("guarded_move_check")
    forces = []  # (receive time, fz) from ft_sensor/wrench
    node.create_subscription(
        WrenchStamped, "ft_sensor/wrench",
        lambda m: forces.append((time.monotonic(), m.wrench.force.z)), 10)
    client = ActionClient(node, GuardedMove, "force_controller/guarded_move")
    try:
        # The estimator trains its default model on first use (~10-20 s).
        touched = spin_for(node, 120, lambda: any(f > 0.05 for _, f in forces))
        check("contact", touched, f"{len(forces)} ft_sensor/wrench messages")
        if touched:
            t0 = next(t for t, f in forces if f > 0.05)
            spin_for(node, 6)
            after = [(t - t0, f) for t, f in forces if t >= t0]
            end = after[-1][0]
            peak = max(f for _, f in after)
            last1 = [f for t, f in after if t > end - 1.0]
            last2 = [f for t, f in after if t > end - 2.0]
            err = abs(statistics.mean(last1) - 1.0)
            sd = statistics.stdev(last2)
            check("overshoot <= 0.1 N", peak - 1.0 <= 0.1, f"peak {peak:.3f} N")
            check("steady-state error <= 0.05 N", err <= 0.05, f"{err:.4f} N")
            check("sd over the last 2 s <= 0.02 N", sd <= 0.02, f"{sd:.4f} N")
        check("action server", client.wait_for_server(timeout_sec=10), "force_controller/guarded_move")
        res, why = send_goal(node, client, GuardedMove.Goal(), 30)
        ok = res is not None and res.status == GoalStatus.STATUS_SUCCEEDED and res.result.reason == "hold"
        check("goal ends holding", ok, why or f"status {res.status}, reason {res.result.reason!r}, "
              f"force {res.result.force_n:.3f} N")
        fast = GuardedMove.Goal(speed_mps=0.2)
        res, why = send_goal(node, client, fast, 10)
        reason = "" if res is None else res.result.reason
        ok = (res is not None and res.status == GoalStatus.STATUS_ABORTED
              and reason.startswith("refused:") and "at most 0.0410 m/s" in reason)
        check("0.2 m/s refused, limit named", ok, why or reason[:160])
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
        node.destroy_node()
        rclpy.shutdown()
    failed = RESULTS.count(False)
    for name in sorted(os.listdir(logs)):
        if failed and name.endswith(".log"):
            print(f"== {name} (last lines)")
            with open(os.path.join(logs, name)) as f:
                print("".join(f.readlines()[-15:]))
    if not failed:
        shutil.rmtree(logs)
    print(f"{len(RESULTS) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
