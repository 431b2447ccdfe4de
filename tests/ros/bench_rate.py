"""How fast the estimator and the controller keep up over DDS: an rclpy
peer publishes BioTac readings (freshly stamped, out of contact) and joint
states at 100 Hz to wrench_estimator and force_controller (the guarded
scene's parameters), at rising reading rates. Per rate, from /diagnostics:
the share of readings the controller stepped on (it steps on the newest
estimate whose mean and std are both in, and skips older ones), the delay
from a reading's stamp to the control step on it (p50 / p99), the readings
the estimator dropped, and the CPU of each node.

Run after scripts/ros2-jazzy.sh:  . target/ros2/env.sh && python tests/ros/bench_rate.py
The peer is Python: at the top rates its own publishing may be the limit;
the "sent" column says what it achieved.
"""

import os
import sys
import time

import rclpy
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_over_dds import REPO, Nodes, Peer  # noqa: E402
from tactile_force_msgs.msg import BioTac  # noqa: E402

RATES_HZ = (100, 200, 500, 1000, 2000)
SECONDS = 4.0
JOINTS = ["S1", "S2", "S3", "E1", "E2", "W1", "W2"]
# config/world.yaml start_joints_deg, in rad: a pose away from singularities.
START_RAD = [0.0, 0.5236, 0.0, 1.5708, 0.0, 1.0472, 0.0]


def stamp(msg, now):
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(now), int((now % 1) * 1e9)


def run_rate(n, peer, readings, joints, rate):
    reading = BioTac(electrodes=[2000] * 19, pdc=2000, pac=[2048] * 22, tdc=2500, tac=2000)
    reading.serial = "bench"
    js = JointState(name=JOINTS, position=START_RAD)
    fc = lambda key: peer.diagnostics.get("force_controller", {}).get(key)  # noqa: E731
    we = lambda key: int(peer.diagnostics.get("wrench_estimator", {}).get(key, 0))  # noqa: E731
    dropped0 = sum(we(k) for k in ("dropped_refused", "dropped_stale", "dropped_non_finite"))
    cpu0 = n.cpu_s()
    delays = []
    t0 = time.monotonic()
    sent, next_js = 0, t0
    while (now := time.monotonic()) - t0 < SECONDS:
        due = t0 + sent / rate
        if now >= due:
            stamp(reading, time.time())
            reading.seq = sent % 65536
            readings.publish(reading)
            sent += 1
        if now >= next_js:
            stamp(js, time.time())
            joints.publish(js)
            next_js += 0.01
        rclpy.spin_once(peer.node, timeout_sec=0.0)
        if fc("loop_delay_p99_ms") is not None:
            delays.append((float(fc("loop_delay_p50_ms")), float(fc("loop_delay_p99_ms")),
                           int(fc("loop_delay_steps"))))
            peer.diagnostics["force_controller"].pop("loop_delay_p99_ms")
        time.sleep(max(0.0, min(due + 1.0 / rate, next_js) - time.monotonic()) * 0.5)
    wall = time.monotonic() - t0
    peer.spin(0.5)
    cpu1 = n.cpu_s()
    dropped = sum(we(k) for k in ("dropped_refused", "dropped_stale", "dropped_non_finite")) - dropped0
    # Whole seconds inside the run (the first report may cover the previous rate).
    inside = delays[1:] or delays
    p50 = max((d[0] for d in inside), default=float("nan"))
    p99 = max((d[1] for d in inside), default=float("nan"))
    steps = sum(d[2] for d in inside) / max(len(inside), 1)
    cpu = ", ".join(f"{exe} {100 * (cpu1[exe] - cpu0[exe]) / wall:.0f} %" for exe in cpu1)
    print(f"| {rate} | {sent / wall:.0f} | {100 * steps / (sent / wall):.1f} % | {p50:.2f} / {p99:.2f} | "
          f"{dropped} | {cpu} |", flush=True)


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    n = Nodes("guarded_move.yaml", "wooden_box", only=("wrench_estimator", "force_controller"))
    peer = Peer(n.domain)
    try:
        readings = peer.node.create_publisher(BioTac, "biotac/readings", qos_profile_sensor_data)
        joints = peer.node.create_publisher(JointState, "joint_states", 10)
        # The estimator tares on its first readings; the controller needs both inputs.
        run_rate(n, peer, readings, joints, 100)
        print("| readings per s asked | sent | stepped on | stamp -> step p50 / p99 (ms, worst second) "
              "| dropped by the estimator | CPU of one core |")
        print("|---|---|---|---|---|---|")
        for rate in RATES_HZ:
            run_rate(n, peer, readings, joints, rate)
    finally:
        peer.destroy()
        n.stop(keep_logs=False)


if __name__ == "__main__":
    main()
