"""The nodes over DDS: our executables as separate processes, started with
the launch files' node list (launch/tactile_force_nodes.py), and an
independent rclpy peer that checks them from the topics and the action.

- Guarded move, each object: the move started at launch touches it and holds
  1 N, measured on ft_sensor/wrench: overshoot <= 0.1 N, steady-state error
  <= 0.05 N over the last second, standard deviation <= 0.02 N over the last
  2 s.
- On the wooden box, GuardedMove goals: the parameters' values end with
  `hold`; a goal canceled on its way ends `canceled`; moving away with
  nothing to touch ends with `timeout`; 0.2 m/s, past the safety envelope, is aborted with a
  reason naming the limit. While it holds: the latency from a reading's stamp
  to the command that follows it, and the CPU of each node.
- Guided move against the fingertip: RMS force error <= 0.3 N per axis while
  the finger pushes.
- biotac_driver on the serial bridge emulator's pseudo-terminal: readings
  at 100 Hz over DDS, and a tare through its ~/tare service.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check, the figures, and "N passed, N failed".
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
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from diagnostic_msgs.msg import DiagnosticArray
from action_msgs.msg import GoalStatus
from tactile_force_msgs.action import GuardedMove
from tactile_force_msgs.msg import BioTac

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(REPO, "launch"))
from tactile_force_nodes import nodes  # noqa: E402

RESULTS = []
CONTACT_N = 0.05


def check(name, ok, detail):
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}", flush=True)


class Nodes:
    """The nodes of a scene, each a process with its log, on a ROS domain of
    their own (so that nothing of another scenario reaches them); the
    estimator first, until its model is loaded (training it on first use
    takes 10-20 s), so that the others start with estimates flowing."""

    def __init__(self, scene, object_name, port=None, only=None):
        self.domain = random.randint(10, 200)
        os.environ["ROS_DOMAIN_ID"] = str(self.domain)
        self.logs = tempfile.mkdtemp(prefix="tactile_force_ros_")
        self.procs = {}
        specs = {exe: (files, overrides)
                 for exe, files, overrides in nodes(scene, port is None, object_name, "", port or "")}
        order = ["wrench_estimator"] + [exe for exe in specs if exe != "wrench_estimator"]
        for exe in [e for e in order if only is None or e in only]:
            self._start(exe, *specs[exe])
            if exe == "wrench_estimator" and not self._wait_log(exe, "wrench_estimator: model", 180):
                raise RuntimeError("the estimator did not load its model:\n" + self.tail(exe))

    def _start(self, exe, files, overrides):
        # Overrides in a parameter file, as launch_ros passes them (an empty
        # string survives this way; `-p model_file:=` does not).
        extra = os.path.join(self.logs, f"{exe}_overrides.yaml")
        with open(extra, "w") as f:
            f.write("/**:\n  ros__parameters:\n")
            for k, v in overrides.items():
                f.write(f"    {k}: \"{v}\"\n")
        cmd = [exe, "--ros-args", "-r", f"__node:={exe}"]
        for name in files:
            cmd += ["--params-file", os.path.join(REPO, "config", name)]
        cmd += ["--params-file", extra]
        log = open(os.path.join(self.logs, f"{exe}.log"), "w")
        self.procs[exe] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=REPO)

    def _wait_log(self, exe, text, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if text in open(os.path.join(self.logs, f"{exe}.log")).read():
                return True
            if self.procs[exe].poll() is not None:
                return False
            time.sleep(0.1)
        return False

    def tail(self, exe, lines=15):
        with open(os.path.join(self.logs, f"{exe}.log")) as f:
            return "".join(f.readlines()[-lines:])

    def cpu_s(self):
        """CPU seconds (user + system) of each node so far."""
        tick = os.sysconf("SC_CLK_TCK")
        out = {}
        for exe, p in self.procs.items():
            with open(f"/proc/{p.pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            out[exe] = (int(fields[11]) + int(fields[12])) / tick
        return out

    def stop(self, keep_logs):
        for p in self.procs.values():
            p.terminate()
        for p in self.procs.values():
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
        if keep_logs:
            for exe in self.procs:
                print(f"== {exe} (last lines)\n{self.tail(exe)}")
        else:
            shutil.rmtree(self.logs)


class Peer:
    """The rclpy node that listens and sends goals, on the nodes' domain."""

    def __init__(self, domain):
        rclpy.init(domain_id=domain)
        self.node = rclpy.create_node(f"tactile_force_check_{os.getpid()}")
        self.forces = []  # (receive time, (fx, fy, fz)) from ft_sensor/wrench
        self.stamps = []  # latest biotac/readings stamp (s) at each command received
        self.latest_stamp = None
        self.node.create_subscription(WrenchStamped, "ft_sensor/wrench", self._on_ft, 10)
        self.node.create_subscription(BioTac, "biotac/readings", self._on_reading, qos_profile_sensor_data)
        self.node.create_subscription(Float64MultiArray, "velocity_controller/commands", self._on_command, 10)
        self.client = ActionClient(self.node, GuardedMove, "force_controller/guarded_move")

    def _on_ft(self, m):
        f = m.wrench.force
        self.forces.append((time.monotonic(), (f.x, f.y, f.z)))

    def _on_reading(self, m):
        self.latest_stamp = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec

    def _on_command(self, _):
        if self.latest_stamp is not None:
            self.stamps.append((time.time(), self.latest_stamp))

    def spin(self, seconds, until=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.02)
            if until is not None and until():
                return True
        return until is None

    def goal(self, goal, timeout, cancel_after=None):
        future = self.client.send_goal_async(goal)
        if not self.spin(10, future.done):
            return None, "no answer to the goal"
        handle = future.result()
        if not handle.accepted:
            return None, "goal rejected"
        if cancel_after is not None:
            self.spin(cancel_after)
            handle.cancel_goal_async()
        result = handle.get_result_async()
        if not self.spin(timeout, result.done):
            return None, f"no result within {timeout} s"
        return result.result(), ""

    def destroy(self):
        self.client.destroy()
        self.node.destroy_node()
        rclpy.shutdown()


def contact_time(forces):
    return next((t for t, f in forces if abs(f[2]) > CONTACT_N), None)


def guarded(object_name):
    n = Nodes("guarded_move.yaml", object_name)
    peer = Peer(n.domain)
    ok = False
    try:
        touched = peer.spin(60, lambda: contact_time(peer.forces) is not None)
        check(f"{object_name}: contact", touched, f"{len(peer.forces)} ft_sensor/wrench messages")
        if touched:
            t0 = contact_time(peer.forces)
            peer.spin(6)
            after = [(t - t0, f[2]) for t, f in peer.forces if t >= t0]
            end = after[-1][0]
            peak = max(f for _, f in after)
            err = abs(statistics.mean([f for t, f in after if t > end - 1.0]) - 1.0)
            sd = statistics.stdev([f for t, f in after if t > end - 2.0])
            check(f"{object_name}: overshoot <= 0.1 N", peak - 1.0 <= 0.1, f"peak {peak:.3f} N")
            check(f"{object_name}: steady-state error <= 0.05 N", err <= 0.05, f"{err:.4f} N")
            check(f"{object_name}: sd over the last 2 s <= 0.02 N", sd <= 0.02, f"{sd:.4f} N")
        if object_name == "wooden_box":
            holding(n, peer)
            goals(peer)
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def holding(n, peer):
    """Latency and CPU while the move holds."""
    peer.stamps.clear()
    cpu0, t0 = n.cpu_s(), time.monotonic()
    peer.spin(5)
    cpu1, wall = n.cpu_s(), time.monotonic() - t0
    lat = sorted((recv - stamp) * 1e3 for recv, stamp in peer.stamps)
    if not lat:
        check("latency measured", False, "no command received")
        return
    p50, p99 = lat[len(lat) // 2], lat[int(0.99 * (len(lat) - 1))]
    rate = len(lat) / wall
    check("commands at 100 Hz", 90 <= rate <= 110, f"{rate:.1f} per s")
    check("reading stamp -> command p50 < 10 ms", p50 < 10.0,
          f"p50 {p50:.2f} ms, p99 {p99:.2f} ms, max {lat[-1]:.2f} ms ({len(lat)} commands)")
    cpu = ", ".join(f"{exe} {100 * (cpu1[exe] - cpu0[exe]) / wall:.1f} %" for exe in cpu1)
    print(f"     CPU of one core while holding: {cpu}", flush=True)


def goals(peer):
    check("action server", peer.client.wait_for_server(timeout_sec=10), "force_controller/guarded_move")
    res, why = peer.goal(GuardedMove.Goal(), 30)
    ok = res is not None and res.status == GoalStatus.STATUS_SUCCEEDED and res.result.reason == "hold"
    check("goal ends holding", ok, why or f"status {res.status}, reason {res.result.reason!r}, "
          f"force {res.result.force_n:.3f} N")
    # Away from the box (+z: the pad faces -z), with nothing to touch.
    away = GuardedMove.Goal(max_distance_m=0.02)
    away.direction.z = 1.0
    res, why = peer.goal(away, 10, cancel_after=0.5)
    ok = res is not None and res.status == GoalStatus.STATUS_CANCELED and res.result.reason == "canceled"
    check("canceled goal", ok, why or f"status {res.status}, reason {res.result.reason!r}")
    res, why = peer.goal(away, 20)
    ok = res is not None and res.status == GoalStatus.STATUS_ABORTED and res.result.reason == "timeout"
    check("nothing within 20 mm: timeout", ok, why or f"status {res.status}, reason {res.result.reason!r}")
    res, why = peer.goal(GuardedMove.Goal(speed_mps=0.2), 10)
    reason = "" if res is None else res.result.reason
    ok = (res is not None and res.status == GoalStatus.STATUS_ABORTED
          and reason.startswith("refused:") and "at most 0.0410 m/s" in reason)
    check("0.2 m/s refused, limit named", ok, why or reason[:120] + "...")


def guided():
    n = Nodes("guided_move.yaml", "fingertip")
    peer = Peer(n.domain)
    ok = False
    try:
        # The finger's path (config/guided_move.yaml) takes 20 s from the
        # start of sim_robot.
        peer.spin(22)
        t0 = contact_time(peer.forces)
        check("guided: contact", t0 is not None, f"{len(peer.forces)} ft_sensor/wrench messages")
        if t0 is not None:
            after = [f for t, f in peer.forces if t >= t0]
            targets = (0.0, 0.0, 1.0)
            rms = [(sum((f[i] - targets[i]) ** 2 for f in after) / len(after)) ** 0.5 for i in range(3)]
            check("guided: RMS force error <= 0.3 N per axis", max(rms) <= 0.3,
                  "fx %.3f, fy %.3f, fz %.3f N" % tuple(rms))
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def driver():
    """biotac_driver on the emulator's pseudo-terminal: readings over DDS,
    and a tare through ~/tare, answered on /diagnostics."""
    # Never pressed (a tare is refused while the skin is pressed).
    emulator = subprocess.Popen(["tactile_force", "biotac-emulator", "--pty", "--press-peak-n", "0"],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    port = emulator.stdout.readline().split()[-1]
    n = Nodes("guarded_move.yaml", "wooden_box", port=port, only=("biotac_driver",))
    peer = Peer(n.domain)
    ok = False
    try:
        got = []
        peer.node.create_subscription(BioTac, "biotac/readings", lambda m: got.append(m), qos_profile_sensor_data)
        diags = []
        peer.node.create_subscription(
            DiagnosticArray, "/diagnostics",
            lambda m: diags.extend(st.message for st in m.status), 10)
        peer.spin(10, lambda: len(got) >= 50)
        t0, n0 = time.monotonic(), len(got)
        peer.spin(2)
        rate = (len(got) - n0) / (time.monotonic() - t0)
        valid = all(len(m.electrodes) == 19 and not m.invalid_channels for m in got)
        check("driver: readings from the emulator over DDS", 90 <= rate <= 110 and valid,
              f"{rate:.1f} per s from {port}, {len(got)} in all, all valid: {valid}")
        tare = peer.node.create_client(Trigger, "biotac_driver/tare")
        ready = tare.wait_for_service(timeout_sec=10)
        answer = tare.call_async(Trigger.Request()) if ready else None
        answered = answer is not None and peer.spin(5, answer.done)
        tared = answered and peer.spin(5, lambda: any(d.startswith("tared") for d in diags))
        check("driver: tare through ~/tare", tared,
              (answer.result().message if answered else "no answer") + "; "
              + next((d for d in diags if d.startswith("tared")), "no tare on /diagnostics"))
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)
        emulator.terminate()
        emulator.wait(timeout=10)


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    for object_name in ("wooden_box", "carton_box", "stuffed_animal"):
        guarded(object_name)
    guided()
    driver()
    failed = RESULTS.count(False)
    print(f"{len(RESULTS) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
