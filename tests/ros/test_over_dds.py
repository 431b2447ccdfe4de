"""The nodes over DDS: our executables as separate processes, started with
the launch files' node list (launch/tactile_force_nodes.py), and an
independent rclpy peer that checks them from the topics and the action.

- Guarded move, each object: the move started at launch touches it and holds
  1 N, measured on ft_sensor/wrench: overshoot <= 0.1 N, steady-state error
  <= 0.05 N over the last second, standard deviation <= 0.02 N over the last
  2 s.
- Each object again, the move started by a GuardedMove goal (after one that
  moves away): it ends `hold` and meets the same bounds.
- On the wooden box, GuardedMove goals: a goal canceled on its way ends
  `canceled`; moving away with nothing to touch ends with `travel_limit`; 2.99 N
  under the 3 N limit ends `force_limit`; 0.2 m/s, past the safety envelope,
  is aborted with a reason naming the limit. While it holds: the latency from a reading's stamp
  to the command that follows it, and the CPU of each node.
- On the wooden box, parameters while running: `task` to guided is refused
  (beyond the safety envelope of the scene's bodies), so are an unknown task and a
  start-up-only parameter, each with its reason, on /rosout too.
- Faults while it holds: undecodable BioTac messages and NaN or mis-sized
  joint states are dropped and counted (/diagnostics) with every node alive;
  a burst of readings at 10x the rate grows neither the loop delay (the
  median of its per-second p99 during the burst, and after it, within one
  period of the quiet seconds' just before it) nor the memory; the
  estimator killed -> zero commands within the stale bound it reports
  (at most 4 periods beyond the estimates' usual age: 3 and the jitter); restarted
  -> it takes up its saved tare and the hold resumes.
- Start-up: every node says what it loaded, on /rosout.
- The BioTac frame on /tf_static (transient local, subscribed after it was
  sent): one transform, the robot file's tip link -> `biotac` (the
  estimator's frame_id), its translation and rotation the file's tool
  mount; for the UR5 too, sent once its description came by topic.
- Guided move against the fingertip, every node started at once as the
  launch files do, from an empty model cache: /diagnostics says the
  estimator is not ready while it trains its default model, then when it
  was; the finger waits for the first estimate; peak force <= 2 N, RMS force
  error <= 0.3 N per axis while the finger pushes, off-axis speed <= 10 % of
  the finger's; then `task` switched to guarded and back.
- Simulated time: sim_robot on /clock at 2x real time, every node with
  use_sim_time: the guarded move holds as in real time.
- biotac_driver on the serial bridge emulator's pseudo-terminal: readings
  at 100 Hz over DDS, and a tare through its ~/tare service.
- `command_interface: twist`: the approach as the BioTac's twist on
  twist_commands (geometry_msgs/TwistStamped, base link frame).
- Calibration on BioTac unit 2 (a unit the default model never saw):
  the force_controller/calibrate action presses the calibration block
  (config/calibrate.yaml) and ends `calibrated`, within 90 s of motion and
  10 s of compute, the F/T sensor never above the 12 N limit; the estimator
  takes the new model without a restart (its model_file says so); then,
  sim_robot and force_controller restarted on the wooden box, the guarded
  move holds within the bounds above, and while it holds the estimator
  refuses another model (the finger is pressed).
- The UR5 (config/ur5.urdf, ur5.yaml), its URDF published on
  /robot_description (transient local) by the peer: until it comes nothing
  is commanded and the nodes say so; then the guarded move on the wooden
  box meets the bounds above, a new description while it holds is refused
  and the hold kept; the guided move meets its bounds.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check, the figures, and "N passed, N failed".
"""

import json
import math
import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import yaml
import rclpy
from rclpy.action import ActionClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.serialization import serialize_message
from geometry_msgs.msg import TwistStamped, WrenchStamped
from rcl_interfaces.msg import Log, Parameter, ParameterType, ParameterValue
from std_msgs.msg import String
from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from diagnostic_msgs.msg import DiagnosticArray
from action_msgs.msg import GoalStatus
from tactile_force_msgs.action import Calibrate, GuardedMove
from tactile_force_msgs.msg import BioTac

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(REPO, "launch"))
from tactile_force_nodes import nodes  # noqa: E402
from checks import RESULTS, check, summary

CONTACT_N = 0.05
PERIOD_S = 0.01


def urdf(robot):
    """A shipped robot's description, config/<robot>.urdf."""
    with open(os.path.join(REPO, "config", f"{robot}.urdf")) as f:
        return f.read()



class Nodes:
    """The nodes of a scene, each a process with its log, on a ROS domain of
    their own (`domain`, else `TACTILE_FORCE_ROS_DOMAIN` when set, as on a
    machine shared with other DDS runs, else a random one: nothing of another
    scenario reaches them); the estimator first, until its model is loaded (training it on first use
    takes 10-30 s), so that the others start with estimates flowing, or, `together`, every node at
    once as the launch files start them; `fresh_cache`: from an empty model cache, as on a new machine;
    `remaps`: {executable: {topic: remapped topic}}."""

    def __init__(self, scene, object_name, port=None, only=None, speed=None, robot="pa10",
                 description_topic=False, controller=None, sim=None, estimator=None, domain=None,
                 together=False, fresh_cache=False, remaps=None):
        self.domain = domain or int(os.environ.get("TACTILE_FORCE_ROS_DOMAIN") or random.randint(10, 200))
        os.environ["ROS_DOMAIN_ID"] = str(self.domain)
        self.logs = tempfile.mkdtemp(prefix="tactile_force_ros_")
        self.procs = {}
        self.remaps = remaps or {}
        cache = {"TACTILE_FORCE_CACHE": os.path.join(self.logs, "cache")} if fresh_cache else {}
        self.env = dict(os.environ, **cache)
        # The URDF as a parameter, as the launch files give it, or none: the
        # nodes then wait for /robot_description.
        description = None if description_topic else urdf(robot)
        started = nodes(scene, port is None, object_name, "", port or "",
                        sim_time=speed is not None, real_time_factor=speed or 1.0,
                        robot=robot, description=description)
        self.robot = robot
        self.specs = {exe: (files, overrides) for exe, files, overrides in started}
        self.specs["force_controller"][1].update(controller or {})
        self.specs["wrench_estimator"][1].update(estimator or {})
        if "sim_robot" in self.specs:
            self.specs["sim_robot"][1].update(sim or {})
        # Each scenario tares anew: its own tare file. The faults' restart
        # comes 60-80 s after the first tare on a slow 2-core machine: past
        # the default tare_max_age_s (60 s) it would tare anew while pressed.
        self.specs["wrench_estimator"][1]["tare_file"] = os.path.join(self.logs, "tare.json")
        self.specs["wrench_estimator"][1]["tare_max_age_s"] = 600.0
        order = ["wrench_estimator"] + [exe for exe in self.specs if exe != "wrench_estimator"]
        for exe in [e for e in order if only is None or e in only]:
            if together:
                self._start(exe, *self.specs[exe])
            else:
                self.start(exe)

    def start(self, exe):
        """Starts `exe`; the estimator until its model is loaded."""
        path = os.path.join(self.logs, f"{exe}.log")
        since = os.path.getsize(path) if os.path.exists(path) else 0
        self._start(exe, *self.specs[exe])
        if exe == "wrench_estimator" and not self.wait_log(exe, "]: model", 180, since):
            raise RuntimeError("the estimator did not load its model:\n" + self.tail(exe))

    def _start(self, exe, files, overrides):
        # Overrides in a parameter file (an empty string survives this way;
        # `-p model_file:=` does not), under the node's name: a node's own
        # section of the config files wins over `/**`, whatever the order.
        extra = os.path.join(self.logs, f"{exe}_overrides.yaml")
        with open(extra, "w") as f:
            f.write(f"{exe}:\n  ros__parameters:\n")
            for k, v in overrides.items():
                # A JSON string is a YAML double-quoted scalar (a URDF's
                # quotes and line breaks escaped).
                value = str(v).lower() if isinstance(v, bool) else v if isinstance(v, (int, float)) else json.dumps(v)
                f.write(f"    {k}: {value}\n")
        # As the launch files start it: its SROS2 enclave named.
        cmd = [exe, "--ros-args", "--enclave", f"/tactile_force/{exe}", "-r", f"__node:={exe}"]
        for topic, to in self.remaps.get(exe, {}).items():
            cmd += ["-r", f"{topic}:={to}"]
        for name in files:
            cmd += ["--params-file", os.path.join(REPO, "config", name)]
        cmd += ["--params-file", extra]
        log = open(os.path.join(self.logs, f"{exe}.log"), "a")
        self.procs[exe] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=REPO, env=self.env)

    def restart_fresh(self, exe, env=None):
        """Starts `exe` anew with its own parameters (stopped first if it
        runs), `env` added to its environment."""
        p = self.procs.get(exe)
        if p is not None and p.poll() is None:
            p.terminate()
            p.wait(timeout=10)
        saved = self.env
        self.env = dict(saved, **(env or {}))
        try:
            self.start(exe)
        finally:
            self.env = saved

    def restart(self, exe, scene, object_name, overrides):
        """Stops `exe` and starts it again as the launch files would for
        `scene` on `object_name`, with `overrides`."""
        self.procs[exe].terminate()
        self.procs[exe].wait(timeout=10)
        spec = next(s for s in nodes(scene, True, object_name, "", "", robot=self.robot,
                                     description=urdf(self.robot)) if s[0] == exe)
        self.specs[exe] = (spec[1], dict(spec[2], **overrides))
        self.start(exe)

    def wait_log(self, exe, text, timeout, since=0):
        """Waits for `text` in the log of `exe` after its first `since` bytes."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if text in self.log(exe)[since:]:
                return True
            if self.procs[exe].poll() is not None:
                return False
            time.sleep(0.1)
        return False

    def tail(self, exe, lines=15):
        with open(os.path.join(self.logs, f"{exe}.log")) as f:
            return "".join(f.readlines()[-lines:])

    def log(self, exe):
        with open(os.path.join(self.logs, f"{exe}.log")) as f:
            return f.read()

    def rss_kib(self):
        """Resident memory of each node (KiB)."""
        out = {}
        for exe, p in self.procs.items():
            with open(f"/proc/{p.pid}/status") as f:
                out[exe] = next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))
        return out

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
        self.ft_stamped = []  # (header stamp, fz) from ft_sensor/wrench
        self.stamps = []  # latest biotac/readings stamp (s) at each command received
        self.commands = []  # (receive time, all velocities zero)
        self.latest = None  # the latest biotac/readings message
        self.logs = []  # /rosout: (logger, level, text)
        self.diagnostics = {}  # /diagnostics: name -> {key: value}, the latest
        self.node.create_subscription(WrenchStamped, "ft_sensor/wrench", self._on_ft, 10)
        self.node.create_subscription(BioTac, "biotac/readings", self._on_reading, qos_profile_sensor_data)
        self.node.create_subscription(Float64MultiArray, "velocity_controller/commands", self._on_command, 10)
        rosout = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(Log, "/rosout", lambda m: self.logs.append((m.name, m.level, m.msg)), rosout)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.client = ActionClient(self.node, GuardedMove, "force_controller/guarded_move")
        # robot_state_publisher's QoS: a late subscriber gets the latest.
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.description = self.node.create_publisher(String, "/robot_description", latched)
        # tf2's static listener's QoS: every transform sent before it joined.
        self.static_tf = []  # the transforms of each /tf_static message
        self.node.create_subscription(TFMessage, "/tf_static", lambda m: self.static_tf.append(m.transforms),
                                      QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                                                 durability=DurabilityPolicy.TRANSIENT_LOCAL))

    def publish_description(self, robot):
        """Publishes config/<robot>.urdf on /robot_description, as
        robot_state_publisher does."""
        self.description.publish(String(data=urdf(robot)))

    def _on_ft(self, m):
        f = m.wrench.force
        self.forces.append((time.monotonic(), (f.x, f.y, f.z)))
        self.ft_stamped.append((m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, f.z))

    def _on_reading(self, m):
        self.latest = m

    def _on_command(self, m):
        if self.latest is not None:
            stamp = self.latest.header.stamp.sec + 1e-9 * self.latest.header.stamp.nanosec
            self.stamps.append((time.time(), stamp))
        self.commands.append((time.monotonic(), all(v == 0.0 for v in m.data)))

    def _on_diagnostics(self, m):
        for st in m.status:
            self.diagnostics[st.name] = {kv.key: kv.value for kv in st.values}

    def set_param(self, node, name, value):
        """Sets a parameter of `node`; (successful, reason)."""
        client = self.node.create_client(SetParameters, f"{node}/set_parameters")
        if not client.wait_for_service(timeout_sec=10):
            return False, "no set_parameters service"
        if isinstance(value, str):
            v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        elif isinstance(value, list):
            v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=value)
        else:
            v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=v)]))
        if not self.spin(10, future.done):
            return False, "no answer"
        r = future.result().results[0]
        self.node.destroy_client(client)
        return r.successful, r.reason

    def get_param(self, node, name):
        """A string parameter of `node`, or None."""
        client = self.node.create_client(GetParameters, f"{node}/get_parameters")
        if not client.wait_for_service(timeout_sec=10):
            return None
        future = client.call_async(GetParameters.Request(names=[name]))
        answered = self.spin(10, future.done)
        self.node.destroy_client(client)
        return future.result().values[0].string_value if answered and future.result().values else None

    def describe_params(self, node, names):
        """The descriptions `node` gives for its parameters `names`, or None."""
        client = self.node.create_client(DescribeParameters, f"{node}/describe_parameters")
        if not client.wait_for_service(timeout_sec=10):
            return None
        future = client.call_async(DescribeParameters.Request(names=names))
        answered = self.spin(10, future.done)
        self.node.destroy_client(client)
        return [d.description for d in future.result().descriptors] if answered else None

    def diagnostic(self, name, key, timeout=3.0):
        """The next value of `key` in the `name` status on /diagnostics."""
        self.diagnostics.pop(name, None)
        self.spin(timeout, lambda: key in self.diagnostics.get(name, {}))
        return self.diagnostics.get(name, {}).get(key)

    def spin(self, seconds, until=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.02)
            if until is not None and until():
                return True
        return until is None

    def goal(self, goal, timeout, cancel_after=None, client=None):
        client = client or self.client
        future = client.send_goal_async(goal)
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


def hold_figures(peer, t0, seconds):
    """Peak, steady-state error (last 1 s) and sd (last 2 s) of fz on
    ft_sensor/wrench, by header stamp, over `seconds` from stamp t0."""
    after = [(t, f) for t, f in peer.ft_stamped if t0 <= t <= t0 + seconds]
    end = after[-1][0]
    peak = max(f for _, f in after)
    err = abs(statistics.mean([f for t, f in after if t > end - 1.0]) - 1.0)
    sd = statistics.stdev([f for t, f in after if t > end - 2.0])
    return peak, err, sd


def check_hold(label, peer, t0, seconds, wall_timeout):
    """Waits for `seconds` of ft_sensor/wrench stamps after t0, then checks
    the hold."""
    peer.spin(wall_timeout, lambda: peer.ft_stamped[-1][0] >= t0 + seconds)
    peak, err, sd = hold_figures(peer, t0, seconds)
    check(f"{label}: overshoot <= 0.1 N", peak - 1.0 <= 0.1, f"peak {peak:.3f} N")
    check(f"{label}: steady-state error <= 0.05 N", err <= 0.05, f"{err:.4f} N")
    check(f"{label}: sd over the last 2 s <= 0.02 N", sd <= 0.02, f"{sd:.4f} N")


def description_by_topic(n, peer, label):
    """The nodes wait for /robot_description, commanding nothing and saying
    so; then the peer publishes the robot's URDF there."""
    peer.spin(2)
    said = [exe for exe in ("sim_robot", "force_controller")
            if "waiting for the robot description on /robot_description" in n.log(exe)]
    check(f"{label}: no description, nothing commanded, and said", not peer.commands and len(said) == 2,
          f"{len(peer.commands)} commands in 2 s; waiting logged by {said}")
    peer.publish_description(n.robot)


def guarded(object_name, speed=None, label=None, robot="pa10"):
    """The guarded move on `object_name`; `speed`: simulated time on /clock
    at that many times real time; `robot`: the PA10 gets its URDF as a
    parameter, another robot from the peer on /robot_description."""
    label = label or object_name
    n = Nodes("guarded_move.yaml", object_name, speed=speed, robot=robot,
              description_topic=robot != "pa10")
    peer = Peer(n.domain)
    ok = False
    try:
        if robot != "pa10":
            description_by_topic(n, peer, label)
        touched = peer.spin(60, lambda: any(abs(f) > CONTACT_N for _, f in peer.ft_stamped))
        check(f"{label}: contact", touched, f"{len(peer.forces)} ft_sensor/wrench messages")
        if touched:
            t0 = next(t for t, f in peer.ft_stamped if abs(f) > CONTACT_N)
            wall0 = time.monotonic()
            check_hold(label, peer, t0, 6.0, 30)
            if speed:
                ratio = (peer.ft_stamped[-1][0] - t0) / (time.monotonic() - wall0)
                check(f"{label}: simulated time runs at {speed}x", abs(ratio / speed - 1) <= 0.2,
                      f"{ratio:.2f} simulated s per wall-clock s")
        if touched and not speed:
            by_goal(label, peer)
        if touched and robot != "pa10":
            tool_frame(peer, robot, label)
            new_description_refused(n, peer, label)
        if touched and object_name == "wooden_box" and not speed and robot == "pa10":
            tool_frame(peer, robot, label)
            startup_logs(peer)
            holding(n, peer)
            goals(peer)
            parameters_guarded(peer)
            faults(n, peer)
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def new_description_refused(n, peer, label):
    """Another robot's description while the move holds: refused, said, and
    the hold kept."""
    since = len(n.log("force_controller"))
    peer.publish_description("pa10")
    refused = peer.spin(3, lambda: "robot description refused: a task is running"
                        in n.log("force_controller")[since:])
    check(f"{label}: a new description while holding is refused", refused and holding_on(peer),
          "refused and logged, the hold kept" if refused else n.tail("force_controller", 3))


def quaternion_rpy(roll, pitch, yaw):
    """(x, y, z, w) of the fixed-axis x-y-z rotation (URDF's rpy), rad."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def tool_frame(peer, robot, label):
    """The BioTac frame on /tf_static: the tip link of config/<robot>.yaml
    -> biotac, at its tool mount."""
    with open(os.path.join(REPO, "config", f"{robot}.yaml")) as f:
        mount = yaml.safe_load(f)["/**"]["ros__parameters"]["robot"]
    want_xyz = mount["tool_xyz_m"]
    want_q = quaternion_rpy(*(math.radians(a) for a in mount["tool_rpy_deg"]))
    peer.spin(5, lambda: peer.static_tf)
    got = [t for ts in peer.static_tf for t in ts]
    if len(got) != 1:
        check(f"{label}: the BioTac frame on /tf_static", False, f"{len(got)} transforms")
        return
    t = got[0].transform
    xyz = (t.translation.x, t.translation.y, t.translation.z)
    q = (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w)
    # q and -q are the same rotation.
    dq = min(max(abs(a - b) for a, b in zip(q, want_q)), max(abs(a + b) for a, b in zip(q, want_q)))
    dxyz = max(abs(a - b) for a, b in zip(xyz, want_xyz))
    frames = (got[0].header.frame_id, got[0].child_frame_id)
    check(f"{label}: the BioTac frame on /tf_static", frames == (mount["tip_link"], "biotac")
          and dxyz < 1e-12 and dq < 1e-12,
          f"{frames[0]} -> {frames[1]}, xyz {xyz}, q ({', '.join(f'{c:.6f}' for c in q)}) "
          f"[mount {want_xyz}, rpy {mount['tool_rpy_deg']} deg]")


def startup_logs(peer):
    """What each node said at start-up, read back from /rosout."""
    peer.spin(1)
    wanted = {"sim_robot": "object wooden_box", "wrench_estimator": "model default",
              "force_controller": "task guarded on wooden_box"}
    for node, text in wanted.items():
        line = next((m for name, level, m in peer.logs if name == node and text in m), None)
        check(f"/rosout: {node} at start-up", line is not None, (line or f"nothing with {text!r}")[:110] + "...")


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


def by_goal(label, peer):
    """Away from the object, then the guarded move again, started by a goal
    with the parameters' values: it ends `hold`, and holds as at launch."""
    if not peer.client.wait_for_server(timeout_sec=10):
        check(f"{label}: action server", False, "force_controller/guarded_move")
        return
    away = GuardedMove.Goal(max_distance_m=0.01)
    away.direction.z = 1.0  # the pad faces -z
    peer.goal(away, 20)
    t_goal = peer.ft_stamped[-1][0]
    res, why = peer.goal(GuardedMove.Goal(), 30)
    ok = res is not None and res.status == GoalStatus.STATUS_SUCCEEDED and res.result.reason == "hold"
    check(f"{label}: a goal ends holding", ok, why or f"status {res.status}, reason {res.result.reason!r}, "
          f"force {res.result.force_n:.3f} N")
    t0 = next((t for t, f in peer.ft_stamped if t > t_goal and abs(f) > CONTACT_N), None)
    if t0 is not None:
        check_hold(f"{label}, by a goal", peer, t0, 6.0, 30)


def goals(peer):
    # Away from the box (+z: the pad faces -z), with nothing to touch.
    away = GuardedMove.Goal(max_distance_m=0.02)
    away.direction.z = 1.0
    res, why = peer.goal(away, 10, cancel_after=0.5)
    ok = res is not None and res.status == GoalStatus.STATUS_CANCELED and res.result.reason == "canceled"
    check("canceled goal", ok, why or f"status {res.status}, reason {res.result.reason!r}")
    res, why = peer.goal(away, 20)
    ok = res is not None and res.status == GoalStatus.STATUS_ABORTED and res.result.reason == "travel_limit"
    check("nothing within 20 mm: travel_limit", ok, why or f"status {res.status}, reason {res.result.reason!r}")
    # Back to the box, to hold 2.99 N under the 3 N force limit: the
    # overshoot passes the limit, the arm retracts and stops.
    res, why = peer.goal(GuardedMove.Goal(target_force_n=2.99), 30)
    ok = res is not None and res.status == GoalStatus.STATUS_ABORTED and res.result.reason == "force_limit"
    check("2.99 N under a 3 N limit: force_limit", ok,
          why or f"status {res.status}, reason {res.result.reason!r}, force {res.result.force_n:.3f} N")
    res, why = peer.goal(GuardedMove.Goal(speed_mps=0.2), 10)
    reason = "" if res is None else res.result.reason
    ok = (res is not None and res.status == GoalStatus.STATUS_ABORTED
          and reason.startswith("refused:") and "at most 0.0238 m/s" in reason)
    check("0.2 m/s refused, limit named", ok, why or reason[:120] + "...")


def parameters_guarded(peer):
    """Sets while running: each refused with its reason, also on /rosout."""
    ok, why = peer.set_param("force_controller", "task", "guided")
    check("task guided refused among the guarded scene's bodies",
          not ok and "pd.max_speed_mps" in why and "unknown" in why, why[:140] + "...")
    ok, why = peer.set_param("force_controller", "task", "fast")
    check("task fast refused", not ok and "guarded, guided or calibrate" in why, why)
    ok, why = peer.set_param("force_controller", "control_period_s", 0.02)
    check("control_period_s refused while running, the live ones named",
          not ok and "read at start-up only" in why and "guided.*" in why, why)
    # Each parameter described by the field that reads it (docs/parameters.md).
    said = peer.describe_params("force_controller", ["pd.max_speed_mps", "guided.deadband_n",
                                                     "objects.fingertip.friction"])
    check("parameters described by their fields", said == [
        "Largest speed the law commands (m/s).", "Deadband on the force error (N).",
        "Coulomb friction coefficient against the skin."], said)
    peer.spin(0.5)
    said = [(level, m) for name, level, m in peer.logs if name == "force_controller"]
    warned = [m for level, m in said if level == Log.WARN]
    stops = [m for level, m in said if m.startswith("phase") and ":" in m]
    check("/rosout: refusals and stop reasons logged", any("task refused" in m for m in warned)
          and any("goal refused" in m for m in warned) and any(m.endswith(": travel_limit") for m in stops),
          f"{len(warned)} warnings from force_controller; stops: {sorted(set(stops))}")


def faults(n, peer):
    """While holding: bad input, a burst, the estimator killed and back."""
    res, why = peer.goal(GuardedMove.Goal(), 30)
    check("holding again", res is not None and res.result.reason == "hold", why or res.result.reason)
    pub = peer.node.create_publisher(BioTac, "biotac/readings", qos_profile_sensor_data)
    joints = peer.node.create_publisher(JointState, "joint_states", 10)
    count = lambda name, key: int(peer.diagnostic(name, key) or "nan")  # noqa: E731 (a missing one fails)
    before_e = count("wrench_estimator", "dropped_refused")
    before_c = count("force_controller", "rejected")
    t_start = peer.ft_stamped[-1][0]
    good = serialize_message(peer.latest)
    for k in range(100):
        pub.publish(good[: 20 + k % 40])  # cut short: arrays of the wrong length
        # NaN positions, or a joint missing.
        bad = JointState(name=["S1", "S2", "S3", "E1", "E2", "W1", "W2"][: 7 - k % 2])
        bad.position = [0.1 if k % 2 else float("nan")] * len(bad.name)
        joints.publish(bad)
        peer.spin(0.01)
    peer.spin(1.5)
    after_e = count("wrench_estimator", "dropped_refused")
    after_c = count("force_controller", "rejected")
    alive = all(p.poll() is None for p in n.procs.values())
    check("cut-short BioTac messages dropped and counted", after_e - before_e >= 95 and alive,
          f"{after_e - before_e} of 100 counted (best-effort QoS), every node alive: {alive}")
    check("NaN and mis-sized joint states dropped and counted", after_c - before_c == 100 and alive,
          f"{after_c - before_c} of 100 counted")
    _, err, sd = hold_figures(peer, t_start, 99)
    check("the hold through bad input", err <= 0.05 and sd <= 0.02 and holding_on(peer),
          f"error {err:.4f} N, sd {sd:.4f} N")

    # A burst for 3 s: each reading of sim_robot published 9 more times as it
    # comes (10x the rate; the copies marked by sensor_index 1, so that they
    # are not copied again). Each copy is stamped as it is sent: the loop
    # delay is then our nodes' under the load, not the age the peer's own
    # copying adds (with the original's stamp, the median p99 during the
    # burst was 9.3 ms on an idle machine, 4.2 ms before it).
    copied, burst_on = [0], [False]

    def copy(m):
        if burst_on[0] and m.sensor_index == 0:
            m.sensor_index = 1
            for _ in range(9):
                now = time.time_ns()
                m.header.stamp.sec, m.header.stamp.nanosec = now // 10**9, now % 10**9
                pub.publish(m)
            copied[0] += 9
    peer.node.create_subscription(BioTac, "biotac/readings", copy, qos_profile_sensor_data)

    def p99_each_second(seconds):
        # The controller's loop delay p99 of each second it reports from now.
        peer.diagnostics.get("force_controller", {}).pop("loop_delay_p99_ms", None)
        t0, p99s = time.monotonic(), []
        while time.monotonic() - t0 < seconds:
            rclpy.spin_once(peer.node, timeout_sec=0.01)
            if "loop_delay_p99_ms" in peer.diagnostics.get("force_controller", {}):
                p99s.append(float(peer.diagnostics["force_controller"].pop("loop_delay_p99_ms")))
        return p99s

    rss_before = n.rss_kib()
    p99_quiet = p99_each_second(3.0)
    burst_on[0], t0 = True, time.monotonic()
    p99_during = p99_each_second(3.0)
    burst_on[0] = False
    rate = copied[0] / (time.monotonic() - t0)
    p99_after = p99_each_second(3.0)
    rss_after = n.rss_kib()
    # A queue that builds up grows the delay through the burst and outlasts
    # it, by far more than a period. The p99 of a quiet second on a loaded
    # 2-core machine already reaches 5-9 ms, and during the burst the peer's
    # copying shares the cores, so the burst is judged against the quiet
    # seconds just before it: the median during the burst, and after it,
    # within one period (10 ms) of theirs. One slow second is the
    # scheduler: reported, not judged.
    median = lambda ds: statistics.median(ds or [float("nan")])  # noqa: E731
    quiet, during, after = median(p99_quiet), median(p99_during), median(p99_after)
    per_s = lambda ds: ", ".join(f"{d:.2f}" for d in ds)  # noqa: E731
    check("burst: no queue (loop delay p99 within one period of the quiet p99)",
          rate >= 800 and during < quiet + 10.0 and after < quiet + 10.0,
          f"{rate:.0f} extra readings per s for 3 s; p99 per second quiet {per_s(p99_quiet)} ms, "
          f"during {per_s(p99_during)} ms, after {per_s(p99_after)} ms")
    growth = {exe: rss_after[exe] - rss_before[exe] for exe in rss_after}
    check("burst: no memory growth (< 1 MiB per node)", max(growth.values()) < 1024,
          ", ".join(f"{exe} {g:+d} KiB" for exe, g in growth.items()))
    check("burst: still holding", holding_on(peer), "phase hold, not halted, regulating")

    # The estimator killed mid-hold, then started again. The controller halts
    # once the newest estimate is older than the bound it reports (its usual
    # age, 3 periods of the estimates beyond and their jitter, at most a
    # period more): within that and one timer period of the kill.
    stale_ms = float(peer.diagnostic("force_controller", "stale_after_ms") or "nan")
    bound_ms = stale_ms + PERIOD_S * 1e3
    t_kill = time.monotonic()
    n.procs["wrench_estimator"].kill()
    peer.spin(1.0)
    zero_at = next((t for t, zero in peer.commands if t > t_kill and zero), None)
    moving = [t for t, zero in peer.commands if t > t_kill + bound_ms / 1e3 and not zero]
    ms = (zero_at - t_kill) * 1e3 if zero_at else float("nan")
    check("estimator killed: zero commands within the stale bound", zero_at is not None and ms <= bound_ms
          and stale_ms <= 4 * PERIOD_S * 1e3 + 10.0 and not moving,
          f"first zero command {ms:.1f} ms after the kill (stale after {stale_ms:.1f} ms); "
          f"{len(moving)} non-zero after {bound_ms:.1f} ms")
    since = len(n.log("wrench_estimator"))
    n.start("wrench_estimator")
    # Loading the model takes 2-4 s on a loaded 2-core machine.
    taken_up = peer.spin(15, lambda: "taking up the tare" in n.log("wrench_estimator")[since:])
    check("restarted estimator takes up its saved tare", taken_up,
          "logged" if taken_up else n.tail("wrench_estimator", 3))
    t_back = peer.ft_stamped[-1][0]
    peer.spin(10, lambda: peer.ft_stamped[-1][0] >= t_back + 3.0)
    _, err, sd = hold_figures(peer, t_back + 1.0, 2.0)
    check("estimator restarted: the controller regulates again and holds 1 N",
          err <= 0.05 and sd <= 0.02 and holding_on(peer), f"error {err:.4f} N, sd {sd:.4f} N")


def holding_on(peer, statuses=3):
    """True when, within the next `statuses` controller statuses (one a
    second), the controller reports its hold, not halted, while moving: not
    every command of the last second is zero (a halted arm in contact would
    keep the force near 1 N too). A single late estimate sends one zero
    command and restarts the settle time, so one status alone can say
    `regulate` on a loaded machine."""
    for _ in range(statuses):
        status = {}
        peer.spin(3, lambda: status.update(peer.diagnostics.pop("force_controller", {})) or "phase" in status)
        recent = [zero for t, zero in peer.commands if t > time.monotonic() - 1.0]
        moving = bool(recent) and recent.count(True) < 0.1 * len(recent)
        if status.get("phase") == "hold" and "halt" not in status and moving:
            return True
        print(f"     controller: {status}, {recent.count(True)} of {len(recent)} commands zero", flush=True)
    return False


# The slowest peak of a push: slower runs are a push's ends split off by
# the measured velocity's noise (a run of one sample at 1.1 mm/s, seen on
# MuJoCo), where 0.1 mm/s of the arm's is 9 %.
PUSH_MPS = 0.005


def off_axis_ratio(arm, finger, since):
    """The largest arm speed along an axis the finger does not push, over
    the peak speed of the finger's push (as `demo` reports it), and where:
    pushes are the runs of finger motion above 1 mm/s between its waits
    that reach PUSH_MPS, counted when they begin at `since` or later; an
    axis is pushed when the finger moves along it in that run. arm, finger:
    {stamp: (vx, vy, vz)}."""
    stamps = sorted(t for t in finger if t in arm)
    speed = lambda v: sum(x * x for x in v) ** 0.5  # noqa: E731
    runs, run = [], []
    for t in stamps + [None]:
        if t is not None and speed(finger[t]) > 1e-3:
            run.append(t)
        elif run:
            runs, run = runs + [run], []
    worst, where = 0.0, "no push"
    for run in (r for r in runs if r[0] >= since):
        peak = max(speed(finger[t]) for t in run)
        if peak < PUSH_MPS:
            continue
        pushed = [max(abs(finger[t][i]) for t in run) > 0.01 * peak for i in range(3)]
        for t in run:
            off = max((abs(arm[t][i]) for i in range(3) if not pushed[i]), default=0.0)
            if off / peak > worst:
                worst = off / peak
                where = (f"push of {len(run)} samples, peak {1e3 * peak:.1f} mm/s, pushed {pushed}; "
                         f"arm {tuple(round(1e3 * v, 1) for v in arm[t])} mm/s")
    return worst, where


def guided(robot="pa10"):
    label = "guided" if robot == "pa10" else f"{robot}, guided"
    # The PA10's scene as the launch files start it on a new machine: every
    # node at once, the estimator training its default model (empty cache).
    fresh = robot == "pa10"
    n = Nodes("guided_move.yaml", "fingertip", robot=robot, description_topic=robot != "pa10",
              together=fresh, fresh_cache=fresh)
    peer = Peer(n.domain)
    arm, finger, estimates = {}, {}, []
    stamp = lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec  # noqa: E731
    linear = lambda m: (m.twist.linear.x, m.twist.linear.y, m.twist.linear.z)  # noqa: E731
    peer.node.create_subscription(TwistStamped, "sim_robot/biotac_twist",
                                  lambda m: arm.__setitem__(stamp(m), linear(m)), 100)
    peer.node.create_subscription(TwistStamped, "sim_robot/finger_twist",
                                  lambda m: finger.__setitem__(stamp(m), linear(m)), 100)
    peer.node.create_subscription(WrenchStamped, "biotac/wrench", lambda m: estimates.append(stamp(m)), 10)
    ok = False
    try:
        if robot != "pa10":
            description_by_topic(n, peer, label)
        if fresh:
            status = lambda: peer.diagnostics.get("wrench_estimator", {})  # noqa: E731
            loading = peer.spin(30, lambda: status().get("model_ready") == "false")
            check(f"{label}, empty model cache: /diagnostics says the estimator is not ready yet", loading,
                  f"{status()}")
        flowing = peer.spin(180, lambda: estimates)
        ready = peer.diagnostic("wrench_estimator", "model_ready_after_s")
        check(f"{label}: estimates flow, /diagnostics says when the model was ready",
              flowing and ready is not None, f"model ready after {ready} s")
        # The finger's path (config/guided_move.yaml) takes 20 s from the
        # first estimate.
        peer.spin(22)
        t0 = contact_time(peer.forces)
        check(f"{label}: contact", t0 is not None, f"{len(peer.forces)} ft_sensor/wrench messages")
        if t0 is not None:
            after = [f for t, f in peer.forces if t >= t0]
            peak = max(sum(v * v for v in f) ** 0.5 for _, f in peer.forces)
            check(f"{label}: peak force <= 2 N", peak <= 2.0, f"{peak:.2f} N")
            targets = (0.0, 0.0, 1.0)
            rms = [(sum((f[i] - targets[i]) ** 2 for f in after) / len(after)) ** 0.5 for i in range(3)]
            check(f"{label}: RMS force error <= 0.3 N per axis", max(rms) <= 0.3,
                  "fx %.3f, fy %.3f, fz %.3f N" % tuple(rms))
            # Pushes from 1 s after contact (the first may begin while the
            # arm still approaches along z).
            touch = next(t for t, f in peer.ft_stamped if abs(f) > CONTACT_N)
            ratio, where = off_axis_ratio(arm, finger, touch + 1.0)
            check(f"{label}: off-axis speed <= 10 % of the finger's", ratio <= 0.10,
                  f"{100 * ratio:.1f} % at most ({where})")
        for task in ("guarded", "guided") if robot == "pa10" else ():
            done, why = peer.set_param("force_controller", "task", task)
            running = peer.diagnostic("force_controller", "task")
            check(f"task switched to {task} while running", done and running == task,
                  f"set: {done} {why}; /diagnostics says {running}")
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def calibration():
    """The calibration action on unit 2, the estimator taking up the new
    model, then the guarded move on the wooden box with it."""
    unit2 = {"sensor_unit": 2}
    n = Nodes("calibrate.yaml", "calibration_block", sim=unit2)
    peer = Peer(n.domain)
    client = ActionClient(peer.node, Calibrate, "force_controller/calibrate")
    feedback = []
    ok, model = False, None
    try:
        before = peer.get_param("wrench_estimator", "model_file")
        check("calibration: the estimator says its model file", bool(before) and before.endswith(".json"),
              f"model_file {before!r}")
        if not client.wait_for_server(timeout_sec=10):
            check("calibration: action server", False, "force_controller/calibrate")
            return
        # A name in models_dir, the model cache folder by default.
        name = f"unit2_{os.getpid()}.json"
        model = os.path.join(os.path.realpath(os.environ["TACTILE_FORCE_CACHE"]), name)
        goal = Calibrate.Goal(model_file=name)
        peer.forces.clear()
        sent = client.send_goal_async(goal, feedback_callback=lambda f: feedback.append(f.feedback))
        peer.spin(10, sent.done)
        result = sent.result().get_result_async() if sent.done() and sent.result().accepted else None
        done = result is not None and peer.spin(240, result.done)
        r = result.result().result if done else None
        status = result.result().status if done else None
        # Better on every axis, or the reason names where it is worse.
        worse = r is not None and any(b > a for a, b in zip(r.current_rmse_n, r.chosen_rmse_n))
        said = "calibrated; worse than the current model on " if worse else "calibrated"
        check("calibration: the action ends calibrated, saying where it is worse", r is not None
              and status == GoalStatus.STATUS_SUCCEEDED and (r.reason.startswith(said) if worse
                                                             else r.reason == said),
              "no result" if r is None else f"status {status}, reason {r.reason!r}, chose {r.chosen!r}; "
              f"held-out RMSE before {[round(v, 3) for v in r.current_rmse_n]}, "
              f"after {[round(v, 3) for v in r.chosen_rmse_n]} N")
        if r is None:
            return
        peak = max((sum(v * v for v in f) ** 0.5 for _, f in peer.forces), default=0.0)
        check("calibration: at most 90 s of motion, 10 s of compute", r.motion_s <= 90 and r.compute_s <= 10,
              f"{r.pushes} pushes, {r.motion_s:.1f} s of motion, {r.compute_s:.1f} s of compute; "
              f"{len(feedback)} feedback messages, the last {feedback[-1].phase if feedback else None!r}")
        check("calibration: the F/T sensor never above the 12 N limit", peak <= 12.0 and r.peak_force_n <= 12.0,
              f"peak {peak:.2f} N on ft_sensor/wrench (the node measured {r.peak_force_n:.2f} N)")
        check("calibration: model and session written", os.path.exists(model) and os.path.exists(r.session_file),
              f"{r.model_file}, {r.session_file}")
        after = peer.get_param("wrench_estimator", "model_file")
        said = "estimating with it from the next reading" in n.log("wrench_estimator")
        check("calibration: the estimator took the new model, no restart",
              r.estimator_updated and after == model and said,
              f"{r.estimator_message}; model_file {after!r}")
        # The guarded move with the calibrated model: the arm and the block
        # give way to the wooden box; the estimator runs on.
        for exe in ("sim_robot", "force_controller"):
            n.restart(exe, "guarded_move.yaml", "wooden_box", unit2 if exe == "sim_robot" else {})
        peer.ft_stamped.clear()
        touched = peer.spin(60, lambda: any(abs(f) > CONTACT_N for _, f in peer.ft_stamped))
        check("unit 2, calibrated: contact", touched, f"{len(peer.ft_stamped)} ft_sensor/wrench messages")
        if touched:
            t0 = next(t for t, f in peer.ft_stamped if abs(f) > CONTACT_N)
            check_hold("unit 2, calibrated, wooden_box", peer, t0, 6.0, 30)
            refused, why = peer.set_param("wrench_estimator", "model_file", before)
            check("a new model while pressed is refused", not refused and "pressed" in why and holding_on(peer),
                  why[:120])
        ok = all(RESULTS)
    finally:
        client.destroy()
        peer.destroy()
        n.stop(keep_logs=not ok)
        for written in (model, model and model[:-len(".json")] + ".mcap"):
            if written and os.path.exists(written):
                os.remove(written)


def twist_interface():
    """command_interface: twist: the BioTac's twist on twist_commands, in the
    base link's frame, instead of joint velocities. sim_robot reads joint
    velocities, so the arm stays where it is and the approach goes on."""
    n = Nodes("guarded_move.yaml", "wooden_box", controller={"command_interface": "twist"})
    peer = Peer(n.domain)
    twists = []
    peer.node.create_subscription(TwistStamped, "twist_commands", twists.append, 100)
    ok = False
    try:
        peer.spin(30, lambda: len(twists) > 10)
        since = len(twists)
        t0 = time.monotonic()
        peer.spin(3)
        rate = (len(twists) - since) / (time.monotonic() - t0)
        last = twists[-1] if twists else None
        lin = (last.twist.linear.x, last.twist.linear.y, last.twist.linear.z) if last else (0, 0, 0)
        ang = (last.twist.angular.x, last.twist.angular.y, last.twist.angular.z) if last else (1, 1, 1)
        # The PA10's pad faces the floor at the start: the approach, 10 mm/s
        # along the pad's normal, is straight down in the base frame.
        ok_twist = (last is not None and last.header.frame_id == "base_link"
                    and max(abs(a - b) for a, b in zip(lin, (0.0, 0.0, -0.01))) < 1e-9
                    and max(abs(a) for a in ang) == 0.0)
        check("command_interface twist: the approach as a twist in base_link, no joint command",
              90 <= rate <= 110 and ok_twist and not peer.commands,
              f"{rate:.1f} twists per s, frame {last.header.frame_id if last else None!r}, "
              f"linear {tuple(round(v, 6) for v in lin)} m/s, angular {ang}; "
              f"{len(peer.commands)} joint commands")
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
    guarded("wooden_box", speed=2.0, label="wooden_box, simulated time at 2x")
    guided()
    guarded("wooden_box", label="ur5, wooden_box", robot="ur5")
    guided(robot="ur5")
    calibration()
    twist_interface()
    driver()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
