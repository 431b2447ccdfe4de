"""Where the time from contact to `hold` goes: one guarded move on MuJoCo's
UR5 over DDS (as tests/ros/hold_sweep.py runs it), the plant's force in
0.1 s bins from contact (0.05 N), with the result and when the force last
left the band before it.

    python tests/ros/trace_guarded.py CYCLE_MS LAG_MS STIFFNESS_N_PER_M

Run after scripts/ros2-jazzy.sh, with `. target/ros2/env.sh`.
"""

import sys
import threading
import time

import rclpy

import hold_sweep as hs
import mujoco_ur5

BAND_N = 0.05  # config/guarded_move.yaml, settle_band_n


def main():
    cycle_ms, lag_ms, k = (float(a) for a in sys.argv[1:4])
    n = hs.mujoco_nodes("guarded_move.yaml")
    rclpy.init(domain_id=n.domain)
    plant = mujoco_ur5.Ur5Plant(("object", k), cycle_ms / 1e3, lag_ms / 1e3)
    node = rclpy.create_node("trace_guarded")
    client = hs.ActionClient(node, hs.GuardedMove, "force_controller/guarded_move")
    spinner = hs.Spinner(plant, node)
    physics = threading.Thread(target=plant.run, args=(40.0,), daemon=True)
    physics.start()
    try:
        end = time.monotonic() + 20.0
        while plant.commands < 100 and time.monotonic() < end:
            time.sleep(0.1)
        got = hs.guarded_result(client, node)
        time.sleep(2.0)
        if got is None:
            sys.exit("no result")
        result, _, t_result = got
        forces = [(t, f[2]) for t, f in plant.truth]
        t0 = next(t for t, f in forces if f > hs.CONTACT_N)
        print(f"result {result.reason} {t_result - t0:.2f} s after contact; stiffness "
              f"{result.stiffness_n_per_m:.1f} N/m, delay {1e3 * result.loop_delay_s:.1f} ms")
        out = [t for t, f in forces if t0 <= t <= t_result and abs(f - 1.0) > BAND_N]
        if out:
            print(f"the force last left the band {max(out) - t0:.2f} s after contact")
        for b in range(int((t_result - t0) / 0.1) + 10):
            fs = [f for t, f in forces if t0 + 0.1 * b <= t < t0 + 0.1 * (b + 1)]
            if fs:
                print(f"{0.1 * b:4.1f} s  {sum(fs) / len(fs):.3f} N")
    finally:
        plant.running = False
        physics.join(timeout=5)
        spinner.stop()
        client.destroy()
        node.destroy_node()
        plant.destroy_node()
        rclpy.shutdown()
        n.stop(keep_logs=False)


if __name__ == "__main__":
    main()
