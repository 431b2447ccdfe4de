"""Soak over DDS: the guarded move holds 1 N on the wooden box for
--minutes, on our simulator. sim_robot, wrench_estimator and
force_controller run as separate processes, started as the tests over DDS
start them (tests/ros/test_over_dds.py, from the launch files' node list),
and an rclpy peer reports each minute:

- fz on ft_sensor/wrench (mean, standard deviation): the hold;
- the resident memory (RSS) of each node at the minute's end;
- the loop delay: force_controller's per-second p99 of the age of each
  estimate's reading when it steps on it (/diagnostics
  `loop_delay_p99_ms`), the median and the largest of the minute's; and the
  p99 over the minute of the estimates' age when the peer receives them
  (biotac/wrench, receive time - header stamp);
- estimates: published by the estimator (its `estimates` count on
  /diagnostics), stepped on by the controller (the sum of its
  `loop_delay_steps`), received by the peer; dropped = published - stepped;
  readings the estimator dropped (its `dropped_*` counts) and messages the
  controller refused (`rejected`). A minute ends at the estimator's next
  report, the controller's steps counted up to it: the two nodes report
  once a second each, so a minute's published and stepped can differ by
  the estimates between their two reports (a few), either way.

Then the memory growth of each node from the end of the first minute to the
end, and the totals. A bench script, not a test (docs/results.md, "Soak").

    scripts/ros2-jazzy.sh && . target/ros2/env.sh
    python scripts/soak_dds.py --minutes 30 --domain 61

Exits 1 when the hold never starts or a node ends before the run does.
"""

import argparse
import os
import statistics
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "tests", "ros"))
import test_over_dds as dds  # noqa: E402  (Nodes, Peer: the nodes as the tests start them)


class Minute:
    """What the peer saw over one minute."""

    def __init__(self):
        self.p99_ms = []  # force_controller's per-second loop delay p99
        self.steps = 0  # estimates the controller stepped on
        self.ages_ms = []  # biotac/wrench age at the peer
        self.halts = set()  # halt reasons force_controller reported

    def on_diagnostics(self, m):
        for st in m.status:
            values = {kv.key: kv.value for kv in st.values}
            if st.name == "force_controller" and "loop_delay_p99_ms" in values:
                self.p99_ms.append(float(values["loop_delay_p99_ms"]))
                self.steps += int(values["loop_delay_steps"])
            if st.name == "force_controller" and "halt" in values:
                self.halts.add(values["halt"])

    def on_wrench(self, m):
        stamp = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
        self.ages_ms.append((time.time() - stamp) * 1e3)


def p99(values):
    v = sorted(values)
    return v[round(0.99 * (len(v) - 1))] if v else float("nan")


def estimator_counts(peer):
    """The estimator's cumulative counts on /diagnostics: estimates, dropped readings."""
    keys = ("estimates", "dropped_refused", "dropped_invalid_channels", "dropped_stale", "dropped_non_finite")
    peer.diagnostic("wrench_estimator", "estimates")
    d = peer.diagnostics.get("wrench_estimator", {})
    return int(d.get("estimates", -1)), sum(int(d.get(k, 0)) for k in keys[1:])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=30.0, help="length of the soak (default 30)")
    ap.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (default: a random one)")
    ap.add_argument("--object", default="wooden_box", help="the object held (config/world.yaml)")
    a = ap.parse_args()
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))

    n = dds.Nodes("guarded_move.yaml", a.object, domain=a.domain)
    peer = dds.Peer(n.domain)
    minute = [Minute()]
    peer.node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: minute[0].on_diagnostics(m), 100)
    peer.node.create_subscription(WrenchStamped, "biotac/wrench", lambda m: minute[0].on_wrench(m), 100)
    status = 0
    try:
        touched = peer.spin(60, lambda: any(abs(f) > dds.CONTACT_N for _, f in peer.ft_stamped))
        if not touched:
            print("no contact within 60 s: the hold never started", file=sys.stderr)
            return 1
        peer.spin(6)  # the approach ends and the hold settles
        print(f"domain {n.domain}, logs {n.logs}; holding 1 N on {a.object} for {a.minutes:g} min", flush=True)
        header = ("| min | fz mean (N) | fz sd (N) | RSS sim_robot / estimator / controller (MiB) "
                  "| loop delay p99 per s, median / max (ms) | estimate age at the peer p99 (ms) "
                  "| estimates published / stepped / received | dropped | readings dropped, refused |")
        print(header)
        print("|---" * (header.count("|") - 1) + "|")
        rows = []
        estimates0, dropped_r0 = estimator_counts(peer)
        rejected0 = int(peer.diagnostic("force_controller", "rejected") or 0)
        minute[0] = Minute()
        peer.ft_stamped.clear()
        t0 = time.monotonic()
        t_end = t0 + 60 * a.minutes
        k = 0
        while time.monotonic() < t_end - 1.0:
            k += 1
            peer.spin(min(t0 + 60 * k, t_end) - time.monotonic())
            # The estimator's count at its next report, and the controller's
            # steps up to then: the two nodes' reports close the minute
            # together (a second apart at most).
            estimates, dropped_r = estimator_counts(peer)
            m, minute[0] = minute[0], Minute()
            dead = [exe for exe, p in n.procs.items() if p.poll() is not None]
            if dead:
                print(f"{', '.join(dead)} ended in minute {k}:\n" + n.tail(dead[0]), file=sys.stderr)
                status = 1
                break
            rss = n.rss_kib()
            rejected = int(peer.diagnostic("force_controller", "rejected") or 0)
            fz = [f for _, f in peer.ft_stamped]
            peer.ft_stamped.clear()
            for buf in (peer.forces, peer.stamps, peer.commands, peer.logs):
                buf.clear()
            published = estimates - estimates0
            row = dict(
                minute=k, fz=statistics.mean(fz) if fz else float("nan"),
                sd=statistics.stdev(fz) if len(fz) > 1 else float("nan"),
                rss={exe: rss[exe] / 1024 for exe in ("sim_robot", "wrench_estimator", "force_controller")},
                p99_med=statistics.median(m.p99_ms) if m.p99_ms else float("nan"),
                p99_max=max(m.p99_ms, default=float("nan")), age_p99=p99(m.ages_ms),
                published=published, stepped=m.steps, received=len(m.ages_ms),
                dropped_r=dropped_r - dropped_r0, rejected=rejected - rejected0, halts=m.halts)
            estimates0, dropped_r0, rejected0 = estimates, dropped_r, rejected
            rows.append(row)
            r = row["rss"]
            print(f"| {k} | {row['fz']:.4f} | {row['sd']:.4f} | {r['sim_robot']:.1f} / "
                  f"{r['wrench_estimator']:.1f} / {r['force_controller']:.1f} | {row['p99_med']:.2f} / "
                  f"{row['p99_max']:.2f} | {row['age_p99']:.2f} | {published} / {m.steps} / {row['received']} "
                  f"| {published - m.steps} | {row['dropped_r']}, {row['rejected']} |"
                  + (f" halted: {', '.join(sorted(m.halts))}" if m.halts else ""), flush=True)
        if len(rows) >= 2:
            first, last = rows[0]["rss"], rows[-1]["rss"]
            growth = ", ".join(f"{exe} {first[exe]:.1f} -> {last[exe]:.1f} MiB ({last[exe] - first[exe]:+.2f})"
                               for exe in first)
            print(f"memory, end of minute 1 -> end of minute {rows[-1]['minute']}: {growth}")
        published = sum(r["published"] for r in rows)
        stepped = sum(r["stepped"] for r in rows)
        print(f"estimates: {published} published, {stepped} stepped on, "
              f"{sum(r['received'] for r in rows)} received by the peer; "
              f"dropped {published - stepped} ({100 * (published - stepped) / max(published, 1):.3f} %); "
              f"readings dropped by the estimator {sum(r['dropped_r'] for r in rows)}, "
              f"messages refused by the controller {sum(r['rejected'] for r in rows)}")
        print(f"loop delay p99 per second: largest {max(r['p99_max'] for r in rows):.2f} ms; "
              f"minutes with a halt: {sum(1 for r in rows if r['halts'])}")
        return status
    finally:
        peer.destroy()
        n.stop(keep_logs=status != 0)


if __name__ == "__main__":
    sys.exit(main())
