"""The wrench estimator on other BioTac messages, over DDS: an rclpy peer
publishes a simulated session's readings, stamped when sent, at 100 Hz, and
checks biotac/wrench and /diagnostics.

- A Shadow hand: `input: biotac_all`, `finger: 2`; the peer publishes
  sr_robot_msgs/BiotacAll on /rh/tactile (the test package
  tests/ros/sr_robot_msgs, Shadow's definitions), the session's readings in
  the ring finger (pac0 = pac1 = its PAC mean) and a pressed reading in
  every other finger. The first 50 (0.5 s out of contact, the model's tare)
  get no estimate; at least 90 % of the others get one, with the message's
  stamp, and its fz is within 0.5 N RMS of the session's label (the model,
  19 electrodes, was trained on that session: this checks the decoding and
  the finger chosen, not the model; nor the timing, which test_over_dds.py
  checks: the node's stale limit is 0.5 s here, so that a busy machine
  loses few readings).
- `finger: 5` stops the node at start-up with exit 2, naming the fingers.
- A BioTac SP: 24-electrode tactile_force_msgs/BioTac on biotac/readings
  and a model trained on 24 electrodes: estimated as above. A model of 19
  electrodes refuses the same messages by name on /diagnostics (level
  ERROR, "model trained on 19 electrodes, readings have 24 electrodes"),
  publishes nothing and keeps running.

Before each stream the peer sends messages the node drops (an electrode
flagged invalid; 20 electrodes in the ring finger) until /diagnostics count
one: readings sent before the node's best-effort subscription matched the
new publisher would be lost (up to 1.8 s of them in one CI run).

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import csv
import math
import os
import random
import subprocess
import sys
import tempfile
import time

import rclpy
from rclpy.qos import qos_profile_sensor_data
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from sr_robot_msgs.msg import Biotac, BiotacAll
from tactile_force_msgs.msg import BioTac
from checks import RESULTS, check, key, summary

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("TACTILE_FORCE_ROS2_BIN", os.path.join(REPO, "target", "release"))
ROWS = 700  # 7 s of the pressing set: one push, to 6.5 N
TARE = 50




def session(work, sensor):
    """A simulated session of `sensor` and a model of fz trained on it:
    (the pressing set's first rows, the model file)."""
    tf = os.path.join(BIN, "tactile_force")
    data, model = os.path.join(work, f"{sensor}.csv"), os.path.join(work, f"{sensor}.json")
    subprocess.run([tf, "collect", "--sensor", sensor, "--trials", "1", "--out", data],
                   check=True, capture_output=True)
    subprocess.run([tf, "train", "--data", data, "--axes", "fz", "--out", model],
                   check=True, capture_output=True)
    rows = [r for r in csv.DictReader(open(data)) if r["set"] == "3"][:ROWS]
    return rows, model


def channels(row):
    """(electrodes, pdc, pac, tdc, tac) of a CSV row, in counts."""
    electrodes = [int(row[f"e{i}"]) for i in range(1, 25) if f"e{i}" in row]
    pdc, tdc, tac = (int(row[c]) for c in ("pdc", "tdc", "tac"))
    return electrodes, pdc, round(float(row["pac_mean"])), tdc, tac


class Estimator:
    """wrench_estimator with `params`, its log in `work`."""

    def __init__(self, work, name, params):
        path = os.path.join(work, f"{name}.yaml")
        with open(path, "w") as f:
            f.write("/**:\n  ros__parameters:\n")
            for k, v in params.items():
                f.write(f"    {k}: {v if isinstance(v, (int, float)) else repr(str(v))}\n")
        self.log_path = os.path.join(work, f"{name}.log")
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen(["wrench_estimator", "--ros-args", "--params-file", path],
                                     stdout=self.log, stderr=subprocess.STDOUT, cwd=REPO)

    def wait_for(self, text, timeout=60):
        end = time.monotonic() + timeout
        while text not in self.text() and time.monotonic() < end and self.proc.poll() is None:
            time.sleep(0.1)
        return text in self.text()

    def text(self):
        return open(self.log_path).read()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=10)
        self.log.close()
        if not all(RESULTS):
            print("== wrench_estimator (last lines)\n" + "".join(self.text().splitlines(True)[-10:]))


class Peer:
    """The rclpy node: the estimates by stamp, the latest diagnostics."""

    def __init__(self):
        self.node = rclpy.create_node(f"tactile_force_hand_check_{os.getpid()}")
        self.estimates, self.diagnostics = {}, {}
        self.node.create_subscription(
            WrenchStamped, "biotac/wrench",
            lambda m: self.estimates.__setitem__(key(m.header.stamp), m.wrench.force.z), 100)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)

    def _on_diagnostics(self, m):
        for s in m.status:
            level = s.level[0] if isinstance(s.level, bytes) else s.level  # a `byte` field
            self.diagnostics[s.name] = (level, s.message, {kv.key: kv.value for kv in s.values})

    def spin(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.005)

    def send(self, kind, topic, rows, make, unusable):
        """Publishes make(row) for each row at 100 Hz, stamped when sent, on
        a publisher of its own (matched anew with the node just started):
        [(stamp, fz)]. Before the rows, unusable() messages, which the node
        drops and counts, until its /diagnostics show one counted: a best
        effort subscription loses what is sent before it has matched the
        publisher, however soon the publisher sees the subscription."""
        pub = self.node.create_publisher(kind, topic, qos_profile_sensor_data)
        end = time.monotonic() + 10
        while pub.get_subscription_count() == 0 and time.monotonic() < end:
            self.spin(0.05)
        self.diagnostics.pop("wrench_estimator", None)
        end = time.monotonic() + 15
        while not self.dropped_any() and time.monotonic() < end:
            msg = unusable()
            msg.header.stamp = self.node.get_clock().now().to_msg()
            pub.publish(msg)
            self.spin(0.05)
        sent = []
        for row in rows:
            msg = make(row)
            msg.header.stamp = self.node.get_clock().now().to_msg()
            pub.publish(msg)
            sent.append((key(msg.header.stamp), float(row["fz"])))
            self.spin(0.01)
        self.spin(1.0)
        self.node.destroy_publisher(pub)
        return sent

    def dropped_any(self):
        values = self.diagnostics.get("wrench_estimator", (0, "", {}))[2]
        return any(k.startswith("dropped_") and v != "0" for k, v in values.items())

    def check_estimates(self, what, sent):
        during_tare = sum(s in self.estimates for s, _ in sent[:TARE])
        got = [(self.estimates[s], fz) for s, fz in sent[TARE:] if s in self.estimates]
        share = len(got) / len(sent[TARE:])
        rmse = math.sqrt(sum((e - fz) ** 2 for e, fz in got) / max(len(got), 1))
        peak = max(fz for _, fz in sent)
        dropped = {k: v for k, v in self.diagnostics.get("wrench_estimator", (0, "", {}))[2].items()
                   if k == "estimates" or k.startswith("dropped_") and v != "0"}
        check(f"{what}: tared, then estimated with the readings' stamps",
              during_tare == 0 and share >= 0.9,
              f"{during_tare} estimates during the tare of {TARE}; "
              f"{len(got)} of the {len(sent) - TARE} readings after it ({share:.1%}); "
              f"the node says {dropped}")
        check(f"{what}: fz within 0.5 N RMS of the labels", got and rmse <= 0.5 and peak > 5,
              f"RMSE {rmse:.3f} N over {len(got)} readings, forces to {peak:.1f} N")


def hand(row, pressed):
    """A BiotacAll: `row` in the ring finger (2), `pressed` in the others."""
    msg = BiotacAll()
    msg.header.frame_id = "rh_palm"
    for finger in range(5):
        electrodes, pdc, pac, tdc, tac = channels(row if finger == 2 else pressed)
        msg.tactiles[finger] = Biotac(pac0=pac, pac1=pac, pdc=pdc, tac=tac, tdc=tdc,
                                      electrodes=electrodes)
    return msg


def biotac(row):
    electrodes, pdc, pac, tdc, tac = channels(row)
    msg = BioTac(electrodes=electrodes, pdc=pdc, pac=[pac] * 22, tdc=tdc, tac=tac)
    msg.header.frame_id = "biotac"
    return msg


def hand_unusable(pressed):
    """A BiotacAll whose ring finger has 20 electrodes: no BioTac's."""
    msg = hand(pressed, pressed)
    msg.tactiles[2].electrodes = [0] * 20
    return msg


def biotac_unusable(row):
    """A BioTac whose driver flagged an electrode invalid."""
    msg = biotac(row)
    msg.invalid_channels = ["e1"]
    return msg


def main():
    work = tempfile.mkdtemp(prefix="tactile_force_hand_")
    rows19, model19 = session(work, "biotac")
    rows24, model24 = session(work, "biotac-sp")
    domain = int(os.environ.get("ROS_DOMAIN_ID") or random.randint(10, 200))
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    rclpy.init(domain_id=domain)
    peer = Peer()
    # A tare of its own for each start; late readings estimated all the same.
    quiet = {"tare_file": os.path.join(work, "tare.json"), "tare_max_age_s": 0, "stale_timeout_s": 0.5}

    # A finger the hand does not have: refused at start-up.
    bad = Estimator(work, "bad_finger", {"model_file": model19, "input": "biotac_all", "finger": 5})
    code = bad.proc.wait(timeout=60)
    check("finger 5 of a Shadow hand refused at start-up", code == 2 and "holds 5 BioTacs" in bad.text(),
          f"exit {code}: {bad.text().strip().splitlines()[-1] if bad.text().strip() else ''}")
    bad.stop()

    # The ring finger of a Shadow hand.
    e = Estimator(work, "hand", dict(quiet, model_file=model19, input="biotac_all", finger=2))
    try:
        e.wait_for("reading sr_robot_msgs/msg/BiotacAll on /rh/tactile")
        pressed = max(rows19, key=lambda r: float(r["fz"]))
        sent = peer.send(BiotacAll, "/rh/tactile", rows19, lambda row: hand(row, pressed),
                         lambda: hand_unusable(pressed))
        peer.check_estimates("Shadow hand, finger 2", sent)
    finally:
        e.stop()

    # A BioTac SP on our message: a 24-electrode model, then a 19-electrode one.
    ours = "reading tactile_force_msgs/msg/BioTac on biotac/readings"
    e = Estimator(work, "sp", dict(quiet, model_file=model24))
    try:
        e.wait_for(ours)
        sent = peer.send(BioTac, "biotac/readings", rows24, biotac, lambda: biotac_unusable(rows24[0]))
        peer.check_estimates("BioTac SP, 24 electrodes", sent)
    finally:
        e.stop()
    e = Estimator(work, "sp_on_19", dict(quiet, model_file=model19))
    try:
        e.wait_for(ours)
        peer.estimates.clear()
        peer.diagnostics.clear()
        sent = peer.send(BioTac, "biotac/readings", rows24[:200], biotac,
                         lambda: biotac_unusable(rows24[0]))
        end = time.monotonic() + 3
        while peer.diagnostics.get("wrench_estimator", (0, "", {}))[0] != 2 and time.monotonic() < end:
            peer.spin(0.05)
        level, message, values = peer.diagnostics.get("wrench_estimator", (None, "", {}))
        dropped = int(values.get("dropped_layout", "0"))
        check("a 19-electrode model refuses 24-electrode readings by name",
              level == 2 and "model trained on 19 electrodes, readings have 24 electrodes" in message
              and dropped >= 0.9 * len(sent) and not peer.estimates and e.proc.poll() is None,
              f"level {level}, \"{message}\", {dropped} of {len(sent)} dropped, "
              f"{len(peer.estimates)} estimates")
    finally:
        e.stop()
    peer.node.destroy_node()
    rclpy.shutdown()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
