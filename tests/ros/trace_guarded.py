"""Where the time from contact to `hold` goes: one guarded move on MuJoCo's
UR5 over DDS (as tests/ros/hold_sweep.py runs it), the plant's force in
0.1 s bins from contact (0.05 N), with the result and when the force last
left the band before it.

    python tests/ros/trace_guarded.py CYCLE_MS LAG_MS STIFFNESS_N_PER_M

Run after scripts/ros2-jazzy.sh, with `. target/ros2/env.sh`.
"""

import sys
import time

import hold_sweep as hs

BAND_N = 0.05  # config/guarded_move.yaml, settle_band_n


def main():
    cycle_ms, lag_ms, k = (float(a) for a in sys.argv[1:4])
    with hs.mujoco_guarded(cycle_ms, lag_ms, k) as (plant, node, client):
        got = hs.guarded_result(client, node)
        time.sleep(2.0)
        forces = [(t, f[2]) for t, f in plant.truth]
    if got is None:
        sys.exit("no result")
    result, _, t_result = got
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


if __name__ == "__main__":
    main()
