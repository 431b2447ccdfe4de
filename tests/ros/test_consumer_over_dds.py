"""A node developer's view of the estimate, over DDS: the rclpy consumer of
docs/ros2.md ("For node developers"), taken from the page as a user copies
it, runs beside the guarded scene; an rclpy peer reads
biotac/wrench_estimate against the readings and biotac/wrench.

- One message per reading: at least 95 % of the readings on
  biotac/readings over 5 s have an estimate with their stamp (the others:
  none dropped but the first, tare, ones), at the estimator's rate.
- Each carries the mean (equal to biotac/wrench's on the estimated axes,
  NaN on the others), a finite positive std on the estimated axes, the
  flags of the model's axes, the model's file and the first 16 hex digits
  of that file's SHA-256 (computed here with hashlib), the reading's age
  (0 to stale_timeout_s) and the PDC rise in counts.
- model_file set to another file (the same model written with other
  bytes): the estimates name the new file and its hash from then on, and
  the docs' consumer says the model changed.
- A guarded goal holds on the estimate; the PDC rise is higher in the hold
  than before contact; the docs' consumer prints about 1 N in the hold.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile

from rclpy.qos import qos_profile_sensor_data
from geometry_msgs.msg import WrenchStamped
from tactile_force_msgs.action import GuardedMove
from tactile_force_msgs.msg import BioTac, WrenchEstimate

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, key, summary  # noqa: E402
from test_over_dds import REPO, Nodes, Peer  # noqa: E402

STALE_S = 0.03  # config/guarded_move.yaml: wrench_estimator.stale_timeout_s


def stamp(m):
    return key(m.header.stamp)


def docs_consumer():
    """The Python consumer of docs/ros2.md, as a user copies it."""
    with open(os.path.join(REPO, "docs", "ros2.md")) as f:
        page = f.read()
    section = page[page.index("## For node developers"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def sha16(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


class Seen:
    """What the peer received, by reading stamp."""

    def __init__(self, peer):
        self.readings, self.estimates, self.means = [], {}, {}
        peer.node.create_subscription(BioTac, "biotac/readings", lambda m: self.readings.append(stamp(m)),
                                      qos_profile_sensor_data)
        peer.node.create_subscription(WrenchEstimate, "biotac/wrench_estimate", self._on_estimate,
                                      qos_profile_sensor_data)
        peer.node.create_subscription(WrenchStamped, "biotac/wrench",
                                      lambda m: self.means.__setitem__(stamp(m), m.wrench), 100)

    def _on_estimate(self, m):
        self.estimates[stamp(m)] = m


def fields(seen, model_file):
    """The checks of each estimate's fields over the last 5 s."""
    last = list(seen.estimates.values())[-500:]
    axes = lambda w: (w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z)  # noqa: E731
    bad = []
    for m in last:
        flags = list(m.estimated)
        mean, std = axes(m.wrench), axes(m.stddev)
        plain = seen.means.get(stamp(m))
        plain = axes(plain) if plain is not None else None
        for i, on in enumerate(flags):
            if on and not (math.isfinite(mean[i]) and math.isfinite(std[i]) and std[i] > 0
                           and (plain is None or plain[i] == mean[i])):
                bad.append(f"axis {i}: mean {mean[i]}, std {std[i]}, biotac/wrench {plain and plain[i]}")
            if not on and not (math.isnan(mean[i]) and math.isnan(std[i])):
                bad.append(f"axis {i} not estimated: mean {mean[i]}, std {std[i]}")
        if not (0.0 <= m.reading_age_s <= STALE_S and math.isfinite(m.pdc_rise_counts)):
            bad.append(f"age {m.reading_age_s}, pdc {m.pdc_rise_counts}")
    compared = sum(stamp(m) in seen.means for m in last)
    check("each estimate: mean as on biotac/wrench, std > 0 where estimated, NaN elsewhere, age within "
          f"{STALE_S} s", last and not bad and compared > 0.9 * len(last),
          f"{len(last)} estimates, {compared} compared with biotac/wrench, axes {list(last[-1].estimated)}, "
          f"age p50 {sorted(m.reading_age_s for m in last)[len(last) // 2] * 1e3:.2f} ms; "
          f"{bad[:3]}" if last else "none")
    names = {(m.model_file, m.model_sha256) for m in last}
    expected = (model_file, sha16(model_file))
    check("each estimate names its model file and the start of its SHA-256", names == {expected},
          f"{names} (hashlib: {expected[1]})")


def rate(peer, seen):
    """Estimates per reading, and per second, over 5 s."""
    r0, e0 = len(seen.readings), set(seen.estimates)
    peer.spin(5.0)
    readings = seen.readings[r0:]
    estimated = [s for s in readings if s in seen.estimates]
    new = len(set(seen.estimates) - e0)
    check("one estimate per reading, at the estimator's rate", len(estimated) >= 0.95 * len(readings) > 0,
          f"{len(estimated)} of {len(readings)} readings have theirs; {new / 5.0:.1f} estimates/s")


def swap_model(peer, seen, first, second):
    """model_file set to `second`, the model of `first` written with other
    bytes: the new name and hash on the estimates from then on."""
    with open(first) as f:
        model = json.load(f)
    with open(second, "w") as f:
        json.dump(model, f, indent=1)
    ok, why = peer.set_param("wrench_estimator", "model_file", second)
    before = len(seen.estimates)
    peer.spin(2.0)
    after = list(seen.estimates.values())[before:]
    named = {(m.model_file, m.model_sha256) for m in after[5:]}
    check("model_file set: the estimates name the new file and its SHA-256",
          ok and named == {(second, sha16(second))} and sha16(second) != sha16(first),
          f"set: {ok} {why!r}; {named}")


def hold(peer, seen, consumer_log):
    """A guarded goal holds on the estimate; the PDC rises; the docs'
    consumer prints about 1 N."""
    before = [m.pdc_rise_counts for m in list(seen.estimates.values())[-100:]]
    result, why = peer.goal(GuardedMove.Goal(), 60)
    reason = result.result.reason if result else why
    check("a guarded goal holds on biotac/wrench_estimate", reason == "hold", reason)
    peer.spin(1.0)
    during = [m.pdc_rise_counts for m in list(seen.estimates.values())[-100:]]
    check("the PDC rise in counts: higher in the hold than before contact",
          before and during and min(during) > max(before),
          f"before: at most {max(before, default=math.nan):.1f}, hold: at least {min(during, default=math.nan):.1f}")
    with open(consumer_log) as f:
        printed = [float(x) for x in re.findall(r"fz ([+-]\d+\.\d+) N", f.read())]
    check("the docs' consumer prints about 1 N in the hold", printed and abs(abs(printed[-1]) - 1.0) < 0.2,
          f"{len(printed)} lines, the last {printed[-1] if printed else None}")


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    n = Nodes("guarded_move.yaml", "wooden_box", controller={"autostart": False})
    peer = Peer(n.domain)
    seen = Seen(peer)
    work = tempfile.mkdtemp(prefix="tactile_force_consumer_")
    consumer = os.path.join(work, "consumer.py")
    with open(consumer, "w") as f:
        f.write(docs_consumer())
    log = os.path.join(work, "consumer.log")
    proc = subprocess.Popen([sys.executable, consumer], stdout=open(log, "w"), stderr=subprocess.STDOUT,
                            env=n.env)
    second = None
    ok = False
    try:
        peer.spin(15, lambda: len(seen.estimates) > 100)
        model_file = peer.get_param("wrench_estimator", "model_file")
        rate(peer, seen)
        fields(seen, model_file)
        with open(log) as f:
            said = f.read()
        check("the docs' consumer: the model named once, fz lines at the estimator's rate",
              said.count("]: model ") == 1 and said.count(": fz ") > 100,
              f"{said.count(']: model ')} model lines, {said.count(': fz ')} fz lines")
        second = os.path.join(os.path.dirname(model_file), f"consumer_{os.getpid()}.json")
        swap_model(peer, seen, model_file, second)
        with open(log) as f:
            said = f.read()
        check("the docs' consumer says the model changed", said.count("]: model ") == 2 and second in said,
              f"{said.count(']: model ')} model lines")
        hold(peer, seen, log)
        ok = summary() == 0
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        peer.destroy()
        n.stop(keep_logs=not ok)
        if second is not None and os.path.exists(second):
            os.remove(second)
        if not ok:
            with open(log) as f:
                print("== the docs' consumer (last lines)\n" + "".join(f.readlines()[-10:]))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
