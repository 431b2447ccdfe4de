"""A BioTac SP through the whole path, over DDS: the Cheetah double
(tests/cheetah_double, built here with cc) answering as BioTac SPs ->
biotac_driver (`interface: cheetah`, `electrodes: 24`, board position 1)
-> wrench_estimator with a model trained on 24 electrodes -> biotac/wrench.

An rclpy peer checks, once it has 300 readings and 200 estimates (at most
20 s after its first reading):
- the readings on biotac/readings: 24 electrodes and 27 PAC samples, every
  value the one the double sent (its hash of position, frame and sample,
  written again below; TDC carries the frame number), sensor_index 1;
- the estimator's biotac/wrench: from the first reading it answered (after
  its tare on the first 50 it received; DDS discovery between the driver
  and the estimator took 3 s on a loaded CI machine, so that is not the
  driver's first), an estimate for at least half the readings, with their
  stamps (251 of 312 on a loaded machine; the nodes' rate is
  test_over_dds.py's to check, not this one's).

The double's values are not a touch, so the estimates' values are not
checked, only that a 24-electrode model takes these readings
(test_hand_over_dds.py checks a model's values on SP readings).

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import os
import random
import subprocess
import sys
import tempfile
import time

import rclpy
from rclpy.qos import qos_profile_sensor_data
from geometry_msgs.msg import WrenchStamped
from tactile_force_msgs.msg import BioTac
from checks import RESULTS, check, key, summary

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("TACTILE_FORCE_ROS2_BIN", os.path.join(REPO, "target", "release"))
TARE = 50
SLOT = 1




def double_value(s, k, p):
    """The double's sample at frame position p of frame k, board position s
    (cheetah_double.c's double_value)."""
    m = 0xFFFFFFFF
    h = (((s + 1) * 0x9E3779B1) & m) ^ ((k * 0x85EBCA77) & m) ^ ((p * 0xC2B2AE3D) & m)
    h ^= h >> 15
    h = (h * 0x2C1B3C6D) & m
    h ^= h >> 12
    return h & 0xFFF


def expected(msg):
    """The SP frame the double sent for this reading's frame number (TDC):
    (electrodes, pac, pdc, tac)."""
    k = msg.tdc
    v = lambda p: double_value(msg.sensor_index, k, p)
    return ([v(2 * i) for i in range(24)], [v(2 * n + 1) for n in range(27)], v(48), v(50))


def start(work, name, params, env=None):
    path = os.path.join(work, f"{name}.yaml")
    with open(path, "w") as f:
        f.write("/**:\n  ros__parameters:\n")
        for k, v in params.items():
            f.write(f"    {k}: {v if isinstance(v, (int, float, list)) else repr(str(v))}\n")
    log = open(os.path.join(work, f"{name}.log"), "w")
    return subprocess.Popen([name, "--ros-args", "--params-file", path], stdout=log,
                            stderr=subprocess.STDOUT, cwd=REPO, env=env)


def wait_for_log(work, name, text, proc, timeout=60):
    end = time.monotonic() + timeout
    path = os.path.join(work, f"{name}.log")
    while text not in open(path).read() and time.monotonic() < end and proc.poll() is None:
        time.sleep(0.1)


def main():
    work = tempfile.mkdtemp(prefix="tactile_force_cheetah_")
    lib = os.path.join(work, "cheetah.so")
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-o", lib,
                    os.path.join(REPO, "tests", "cheetah_double", "cheetah_double.c")], check=True)
    tf = os.path.join(BIN, "tactile_force")
    data, model = os.path.join(work, "sp.csv"), os.path.join(work, "sp.json")
    subprocess.run([tf, "collect", "--sensor", "biotac-sp", "--trials", "1", "--out", data],
                   check=True, capture_output=True)
    subprocess.run([tf, "train", "--data", data, "--axes", "fz", "--out", model],
                   check=True, capture_output=True)
    domain = int(os.environ.get("ROS_DOMAIN_ID") or random.randint(10, 200))
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    rclpy.init(domain_id=domain)
    node = rclpy.create_node(f"tactile_force_cheetah_check_{os.getpid()}")
    readings, estimates = [], set()
    node.create_subscription(BioTac, "biotac/readings", readings.append, qos_profile_sensor_data)
    node.create_subscription(WrenchStamped, "biotac/wrench",
                             lambda m: estimates.add(key(m.header.stamp)), 100)
    procs = []
    try:
        procs.append(start(work, "wrench_estimator", {
            "model_file": model, "tare_file": os.path.join(work, "tare.json"),
            "tare_max_age_s": 0, "stale_timeout_s": 2.0}))
        # The estimator subscribed first: it tares on the driver's first readings.
        wait_for_log(work, "wrench_estimator", "reading tactile_force_msgs/msg/BioTac", procs[0])
        time.sleep(0.5)
        env = dict(os.environ, CHEETAH_DOUBLE_ELECTRODES="24")
        procs.append(start(work, "biotac_driver", {
            "interface": "cheetah", "cheetah": "0", "cheetah_library": lib,
            "sensors": [str(SLOT)], "electrodes": 24.0}, env))
        end = time.monotonic() + 30
        while not readings and time.monotonic() < end and procs[1].poll() is None:
            rclpy.spin_once(node, timeout_sec=0.05)
        end = time.monotonic() + 20
        while (len(readings) < 300 or len(estimates) < 200) and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.005)
        time.sleep(0.5)
        rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
                p.wait(timeout=10)
    shapes = {(len(m.electrodes), len(m.pac), m.sensor_index) for m in readings}
    exact = sum(expected(m) == (list(m.electrodes), list(m.pac), m.pdc, m.tac) for m in readings)
    check("biotac_driver on the Cheetah double: SP readings bit-exact",
          len(readings) >= 100 and shapes == {(24, 27, SLOT)} and exact == len(readings),
          f"{len(readings)} readings, (electrodes, pac, sensor) {sorted(shapes)}, "
          f"{exact} equal to what the double sent")
    stamps = [key(m.header.stamp) for m in readings]
    first = next((i for i, s in enumerate(stamps) if s in estimates), len(stamps))
    # The last few readings may still be on their way through the estimator.
    answerable = stamps[first:-10]
    got = sum(s in estimates for s in answerable)
    check("wrench_estimator with a 24-electrode model estimates them",
          len(answerable) >= 100 and got >= 0.5 * len(answerable),
          f"{got} estimates for the {len(answerable)} readings from the first it answered "
          f"(reading {first}; it tares on its first {TARE})")
    if not all(RESULTS):
        for name in ("biotac_driver", "wrench_estimator"):
            text = open(os.path.join(work, f"{name}.log")).read().splitlines()[-8:]
            print(f"== {name} (last lines)\n" + "\n".join(text))
    node.destroy_node()
    rclpy.shutdown()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
