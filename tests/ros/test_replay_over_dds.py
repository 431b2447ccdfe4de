"""A recorded session played back into wrench_estimator, over DDS, against
`tactile_force eval` on the same file (docs/ros2.md, "Replay a recorded
session").

- The session: the guarded move on the wooden box (sim_robot, the
  estimator, the controller), its biotac/readings and ft_sensor/wrench
  recorded by an rclpy peer into a rosbag2 MCAP with Python's mcap (each
  message's bytes as received, its log time the time it came, as `ros2 bag
  record` writes them; a reading kept with the wrench of its stamp, as the
  calibration records them): from the approach to the hold.
- Offline: `tactile_force eval --model M --test session.mcap --estimates
  offline.csv`, M the model the estimator ran (the scene's default).
- The player: `ros2 bag play` is not installable here, so an rclpy
  stand-in for `ros2 bag play --clock --start-paused` then a resume: it
  reads the file with Python's mcap (not our reader), publishes /clock at
  40 Hz (the player's default), the session's start while paused, then the
  playback time; on resume each recorded message's bytes at its log time
  (divided by --rate). While paused it sends one reading flagged invalid
  until the estimator's /diagnostics count it: a best-effort subscription
  loses what comes before it has matched the publisher (up to 1.8 s in one
  CI run, tests/ros/test_hand_over_dds.py), which a user leaves to the
  pause; and with --clock, until the estimator's /diagnostics are stamped
  with the player's clock.
- use_sim_time:=true, played with --clock at 1x: the readings after
  the tare (50) each have their estimate, by stamp, and the others none;
  /diagnostics count them and no stale one; each estimate's mean equals
  eval's for the reading of its stamp to 1e-9 N on the axes the model
  estimates.
- Without use_sim_time (the usual mistake), played without --clock: every
  reading is dropped as stale, counted on /diagnostics with how to replay
  (use_sim_time:=true, --clock), which the log says once while it counts
  the drops each second.
- use_sim_time:=true, played without --clock: every reading is dropped as
  stale (the node's clock reads no time); the log and /diagnostics say to
  play with --clock.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import csv
import os
import re
import subprocess
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.serialization import deserialize_message
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.srv import GetParameters
from rosgraph_msgs.msg import Clock
from tactile_force_msgs.msg import BioTac, WrenchEstimate
from mcap.reader import make_reader
from mcap.writer import Writer

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, key, summary  # noqa: E402
from test_over_dds import REPO, Nodes  # noqa: E402

BIN = os.environ.get("TACTILE_FORCE_ROS2_BIN", os.path.join(REPO, "target", "release"))

READINGS, FT = "/biotac/readings", "/ft_sensor/wrench"
TARE = 50  # readings the default model's tare takes (the estimator's and eval's)
CLOCK_HZ = 40.0  # ros2 bag play --clock's default rate
TOLERANCE_N = 1e-9
AXES = ("fx", "fy", "fz", "tx", "ty", "tz")
HINT = "use_sim_time:=true"  # both hints name the fix with these
PLAY_CLOCK = "--clock"

SEPARATOR = "=" * 80
HEADER = ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n")
TIME = ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n")


def schema(main, *deps):
    """A message definition and its dependencies, as rosbag2 stores one."""
    return "\n".join([main] + [f"{SEPARATOR}\nMSG: {name}\n{text}" for name, text in deps]).encode()


def biotac_schema():
    with open(os.path.join(REPO, "msg", "msg", "BioTac.msg")) as f:
        return schema(f.read(), HEADER, TIME)


WRENCH_STAMPED_SCHEMA = schema(
    "std_msgs/Header header\nWrench wrench\n", HEADER, TIME,
    ("geometry_msgs/Wrench", "Vector3 force\nVector3 torque\n"),
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"))


def seconds(stamp):
    return stamp.sec + 1e-9 * stamp.nanosec


class Peer:
    """The rclpy side, spun in a thread of its own: what it records and
    receives; the player publishes from the main thread."""

    def __init__(self, domain):
        rclpy.init(domain_id=domain)
        self.node = rclpy.create_node(f"tactile_force_replay_check_{os.getpid()}")
        self.recording = False
        self.readings, self.wrenches = {}, {}  # (sec, nanosec) -> (log time ns, bytes)
        self.peak_fz = 0.0
        self.estimates = {}  # stamp key -> WrenchEstimate
        self.diagnostics = None  # the estimator's latest (stamp, level, message, values)
        reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(BioTac, "biotac/readings", self._on_reading, qos_profile_sensor_data,
                                      raw=True)
        self.node.create_subscription(WrenchStamped, "ft_sensor/wrench", self._on_wrench,
                                      qos_profile_sensor_data, raw=True)
        self.node.create_subscription(WrenchEstimate, "biotac/wrench_estimate",
                                      lambda m: self.estimates.__setitem__(key(m.header.stamp), m), reliable)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_reading(self, data):
        if self.recording:
            m = deserialize_message(data, BioTac)
            self.readings[(m.header.stamp.sec, m.header.stamp.nanosec)] = (time.time_ns(), data)

    def _on_wrench(self, data):
        if self.recording:
            m = deserialize_message(data, WrenchStamped)
            self.wrenches[(m.header.stamp.sec, m.header.stamp.nanosec)] = (time.time_ns(), data)
            self.peak_fz = max(self.peak_fz, abs(m.wrench.force.z))

    def _on_diagnostics(self, m):
        for s in m.status:
            if s.name == "wrench_estimator":
                level = s.level[0] if isinstance(s.level, bytes) else s.level  # a `byte` field
                self.diagnostics = (m.header.stamp, level, s.message, {kv.key: kv.value for kv in s.values})

    def value(self, name, default=-1):
        return int(self.diagnostics[3].get(name, default)) if self.diagnostics else default

    def get_param(self, node, name):
        client = self.node.create_client(GetParameters, f"{node}/get_parameters")
        try:
            if not client.wait_for_service(timeout_sec=10):
                return None
            future = client.call_async(GetParameters.Request(names=[name]))
            end = time.monotonic() + 10
            while not future.done() and time.monotonic() < end:
                time.sleep(0.02)
            return future.result().values[0].string_value if future.done() else None
        finally:
            self.node.destroy_client(client)

    def destroy(self):
        self.executor.shutdown()
        self.thread.join(timeout=5)
        self.node.destroy_node()
        rclpy.shutdown()


def record(peer, path, seconds_max=30.0, hold_s=5.0):
    """Records the guarded move from its approach until `hold_s` after the
    F/T force first reached 0.9 N; writes the paired messages to `path`
    (rosbag2 MCAP). (readings written, peak F/T force in N)."""
    peer.recording = True
    end, held = time.monotonic() + seconds_max, None
    while time.monotonic() < end and (held is None or time.monotonic() < held + hold_s):
        if held is None and peer.peak_fz >= 0.9:
            held = time.monotonic()
        time.sleep(0.05)
    peer.recording = False
    time.sleep(0.1)  # a callback under way ends
    pairs = sorted(set(peer.readings) & set(peer.wrenches))
    messages = sorted([(peer.readings[s][0], READINGS, peer.readings[s][1]) for s in pairs]
                      + [(peer.wrenches[s][0], FT, peer.wrenches[s][1]) for s in pairs])
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="tactile_force tests/ros/test_replay_over_dds.py")
        channels = {}
        for topic, name, text in ((READINGS, "tactile_force_msgs/msg/BioTac", biotac_schema()),
                                  (FT, "geometry_msgs/msg/WrenchStamped", WRENCH_STAMPED_SCHEMA)):
            sid = w.register_schema(name=name, encoding="ros2msg", data=text)
            channels[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
        for i, (log_ns, topic, data) in enumerate(messages):
            w.add_message(channels[topic], log_time=log_ns, data=data, publish_time=log_ns, sequence=i)
        w.finish()
    return len(pairs), peer.peak_fz


def read_session(path):
    """The file as an independent reader sees it: [(log time ns, topic,
    bytes)] in log-time order, and the readings' stamps in stamp order."""
    with open(path, "rb") as f:
        messages = [(m.log_time, c.topic, m.data) for _, c, m in make_reader(f).iter_messages(log_time_order=True)]
    stamps = sorted((deserialize_message(d, BioTac).header.stamp for _, t, d in messages if t == READINGS),
                    key=seconds)
    return messages, stamps


def offline(model, session, out):
    """`eval --estimates` on the session: its CSV's rows, in the file's
    order (row i: the i-th reading by stamp)."""
    tf = os.path.join(BIN, "tactile_force")
    run = subprocess.run([tf, "eval", "--model", model, "--test", session, "--estimates", out],
                         capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"eval: exit {run.returncode}: {run.stderr.strip()}")
    with open(out) as f:
        return list(csv.DictReader(f))


class Player:
    """The stand-in for `ros2 bag play [--clock] [--start-paused] [--rate R]`."""

    def __init__(self, peer, messages):
        self.peer, self.messages = peer, messages
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)  # rosbag2's default offer
        self.pubs = {READINGS: peer.node.create_publisher(BioTac, READINGS, qos),
                     FT: peer.node.create_publisher(WrenchStamped, FT, qos)}
        self.clock = peer.node.create_publisher(Clock, "/clock", QoSProfile(depth=1,
                                                reliability=ReliabilityPolicy.RELIABLE))
        first = next(d for _, t, d in messages if t == READINGS)
        self.probe = deserialize_message(first, BioTac)
        self.probe.invalid_channels = ["e1"]

    def tick(self, ns):
        self.clock.publish(Clock(clock=Time(sec=ns // 10**9, nanosec=ns % 10**9)))

    def paused(self, with_clock, timeout=20.0):
        """While paused: /clock at the session's start, a flagged reading
        every 50 ms, until the estimator counted one (and, with the clock,
        stamps its /diagnostics with it). True when it did."""
        start = self.messages[0][0]
        self.peer.diagnostics = None
        end, probe_due = time.monotonic() + timeout, 0.0
        while time.monotonic() < end:
            d = self.peer.diagnostics
            follows = not with_clock or (d and abs(seconds(d[0]) - start / 1e9) < 1e-3)
            if d and follows and self.peer.value("dropped_invalid_channels", 0) >= 1:
                return True
            if with_clock:
                self.tick(start)
            if time.monotonic() >= probe_due:
                self.pubs[READINGS].publish(self.probe)
                probe_due = time.monotonic() + 0.05
            time.sleep(1.0 / CLOCK_HZ)
        return False

    def play(self, rate, with_clock, duration_s=None):
        """Resumes: each message at its log time over `rate` (the first
        `duration_s` of the session's time), /clock at 40 Hz with the
        playback time. The readings played."""
        t0 = self.messages[0][0]
        until = t0 + int(duration_s * 1e9) if duration_s else None
        wall0 = time.monotonic()
        now_ns = lambda: t0 + int((time.monotonic() - wall0) * rate * 1e9)  # noqa: E731
        next_tick = wall0
        played = 0
        for log_ns, topic, data in self.messages:
            if until is not None and log_ns > until:
                break
            due = wall0 + (log_ns - t0) / 1e9 / rate
            while True:
                now = time.monotonic()
                if with_clock and now >= next_tick:
                    self.tick(now_ns())
                    next_tick += 1.0 / CLOCK_HZ
                if now >= due:
                    break
                time.sleep(max(0.0, min(due, next_tick if with_clock else due) - now))
            self.pubs[topic].publish(data)
            played += topic == READINGS
        if with_clock:
            self.tick(now_ns())
        return played


def start_estimator(n, name, model, sim_time):
    """wrench_estimator alone, as the launch files start it, on `model`,
    tared anew: its log's size before it (what this run adds follows)."""
    p = n.procs.get("wrench_estimator")
    if p is not None and p.poll() is None:
        p.terminate()
        p.wait(timeout=10)
    n.specs["wrench_estimator"][1].update(model_file=model, use_sim_time=sim_time, tare_max_age_s=0.0,
                                          tare_file=os.path.join(n.logs, f"tare_{name}.json"))
    since = os.path.getsize(os.path.join(n.logs, "wrench_estimator.log"))
    n.start("wrench_estimator")
    if not n.wait_log("wrench_estimator", "reading tactile_force_msgs/msg/BioTac", 30, since):
        raise RuntimeError("the estimator did not subscribe:\n" + n.tail("wrench_estimator"))
    return since


def settle(peer, estimates, timeout=5.0):
    """Waits until the estimator's /diagnostics count `estimates` (or the
    timeout) and one more report came."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and peer.value("estimates") < estimates:
        time.sleep(0.05)
    time.sleep(1.1)


def replayed(n, peer, player, offline_rows, stamps, model, rate):
    """use_sim_time:=true, played with --clock at `rate`: every reading
    after the tare estimated, none stale, each as eval estimated it."""
    start_estimator(n, f"sim_{rate}", model, True)
    peer.estimates.clear()
    ready = player.paused(with_clock=True)
    t = time.monotonic()
    played = player.play(rate, with_clock=True)
    wall = time.monotonic() - t
    settle(peer, played - TARE)
    keys = [key(s) for s in stamps]
    row_of = {k: i for i, k in enumerate(keys)}
    got = peer.estimates
    during_tare = sum(k in got for k in keys[:TARE])
    missing = [k for k in keys[TARE:] if k not in got]
    stale, counted = peer.value("dropped_stale"), peer.value("estimates")
    check(f"{rate}x with --clock and use_sim_time: one estimate per reading after the tare, none stale",
          ready and played == len(keys) and during_tare == 0 and not missing and len(got) == len(keys) - TARE
          and counted == len(got) and stale == 0,
          f"{played} readings played in {wall:.1f} s; {len(got)} estimates ({during_tare} during the tare of "
          f"{TARE}, {len(missing)} missing); /diagnostics: estimates {counted}, dropped_stale {stale}"
          + ("" if ready else "; the estimator never followed the player's clock"))
    axes = [a for a in AXES if f"{a}_estimate" in offline_rows[0]]
    worst, compared, flags = 0.0, 0, set()
    for k, m in got.items():
        row = offline_rows[row_of[k]] if k in row_of else None
        flags.add(tuple(a for a, on in zip(AXES, m.estimated) if on))
        if row is None:
            worst = float("inf")
            continue
        for a in axes:
            group, axis = (m.wrench.force, a[1]) if a[0] == "f" else (m.wrench.torque, a[1])
            worst = max(worst, abs(getattr(group, axis) - float(row[f"{a}_estimate"])))
        compared += 1
    ages = sorted(m.reading_age_s for m in got.values())
    check(f"{rate}x: each estimate equals eval's for the reading of its stamp to {TOLERANCE_N:g} N",
          compared == len(keys) - TARE and flags == {tuple(axes)} and worst <= TOLERANCE_N,
          f"{compared} compared on {', '.join(axes)} (flags {sorted(flags)}); largest difference {worst:.3g} N; "
          f"reading_age_s {ages[0] * 1e3:.1f} to {ages[-1] * 1e3:.1f} ms" if ages else "no estimate")
    return worst


def said_once(n, since, fix_words):
    """(times the log of this run gives the hint, lines counting drops)."""
    log = n.log("wrench_estimator")[since:]
    lines = [line for line in log.splitlines() if int((re.search(r"(\d+) stale", line) or [0, 0])[1]) > 0]
    hints = [line for line in lines if all(w in line for w in fix_words)]
    return len(hints), len(lines), (hints[0] if hints else "")


def mistaken(n, peer, player, model, sim_time):
    """Played without --clock: every reading dropped as stale, and the
    estimator says how to replay, once in its log, on /diagnostics with
    the count."""
    what = "use_sim_time:=true without --clock" if sim_time else "without use_sim_time"
    since = start_estimator(n, "sim_no_clock" if sim_time else "wall", model, sim_time)
    peer.estimates.clear()
    ready = player.paused(with_clock=False)
    played = player.play(1.0, with_clock=False, duration_s=3.0)
    time.sleep(2.2)  # two more reports
    stamp, level, message, values = peer.diagnostics or (None, None, "", {})
    stale = int(values.get("dropped_stale", -1))
    words = [PLAY_CLOCK] if sim_time else [HINT, PLAY_CLOCK]
    hints, lines, hint = said_once(n, since, words)
    check(f"{what}: every reading dropped as stale, counted, none estimated",
          ready and played > 250 and stale == played and not peer.estimates,
          f"{played} readings played; dropped_stale {stale}; {len(peer.estimates)} estimates")
    check(f"{what}: the log says how to replay once ({' and '.join(words)}), the drops each second",
          hints == 1 and lines >= 3, f"{hints} hint(s) in {lines} lines counting drops: {hint!r}")
    expected = f"{stale} readings dropped as stale"
    check(f"{what}: /diagnostics says it with the count (WARN)",
          level == 1 and expected in message and all(w in message for w in words),
          f"level {level}: {message!r}")


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    started = time.monotonic()
    n = Nodes("guarded_move.yaml", "wooden_box")
    peer = Peer(n.domain)
    # Beside the nodes' logs: kept when a check fails.
    session, out = os.path.join(n.logs, "session.mcap"), os.path.join(n.logs, "offline.csv")
    ok = False
    try:
        model = peer.get_param("wrench_estimator", "model_file")
        pairs, peak = record(peer, session)
        for exe in ("force_controller", "sim_robot", "wrench_estimator"):
            n.procs[exe].terminate()
            n.procs[exe].wait(timeout=10)
        messages, stamps = read_session(session)
        rows = offline(model, session, out)
        check("the session: the approach and the hold, read back by Python's mcap; eval estimates each reading",
              pairs == len(stamps) == len(rows) > 500 and peak >= 0.9 and len(messages) == 2 * pairs,
              f"{len(stamps)} readings and their wrenches over {seconds(stamps[-1]) - seconds(stamps[0]):.1f} s, "
              f"F/T up to {peak:.2f} N; eval: {len(rows)} rows; model {model}")
        player = Player(peer, messages)
        worst = replayed(n, peer, player, rows, stamps, model, rate=1.0)
        mistaken(n, peer, player, model, sim_time=False)
        mistaken(n, peer, player, model, sim_time=True)
        print(f"largest difference from eval: {worst:.3g} N; {time.monotonic() - started:.0f} s")
        ok = summary() == 0
    finally:
        n.stop(keep_logs=not ok)
        peer.destroy()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
