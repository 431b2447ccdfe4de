"""The estimator over DDS on models that are not a plain GP, one after the
other, each trained on the default model's simulated data: the network as
its GPs' prior mean (`train --mean network`), and an ensemble of networks
(`train --family ensemble`). The guarded move holds on the wooden box with
each, the published stddev of fz below the controller's
`out_of_range.max_std_n`; then the peer publishes readings no press makes
(every electrode 1500 counts below its tare, the PDC as it is): the stddev
rises past that limit and the controller's doubt stop ends the task
`out_of_range`, the pad retracted out of contact.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check, the figures, and "N passed, N failed".
"""

import copy
import os
import shutil
import subprocess
import sys
import tempfile
import time

from rclpy.qos import qos_profile_sensor_data
from tactile_force_msgs.msg import BioTac, WrenchEstimate

import test_over_dds as dds
from checks import check, summary

MAX_STD_N = 0.05  # config/world.yaml, force_controller: out_of_range.max_std_n


# (name, `train` options, what the estimator's log says of it): the network
# mean as config/guarded_move.yaml's recipe (fz, sparse GP of 200 inducing
# points), and the ensemble.
MODELS = [
    ("network mean", ["--inducing", "200", "--mean", "network"], "prior mean network"),
    ("ensemble", ["--family", "ensemble"], "ensemble of 5 networks"),
]


def train(work, options):
    """A model of fz trained with `options` on the data the default model is
    trained on (collect --unit 1 --seed 1)."""
    tf = os.path.join(os.environ.get("TACTILE_FORCE_ROS2_BIN", os.path.join(dds.REPO, "target", "release")),
                      "tactile_force")
    data, model = os.path.join(work, "data"), os.path.join(work, "model.json")
    if not os.path.exists(data):
        subprocess.run([tf, "collect", "--unit", "1", "--seed", "1", "--out", data], check=True,
                       capture_output=True)
    subprocess.run([tf, "train", "--data", data, "--axes", "fz", *options, "--out", model], check=True,
                   capture_output=True)
    return model


def doubt(name, peer, stds):
    """Holding on the model, then readings no press makes."""
    t0 = next(t for t, f in peer.ft_stamped if abs(f) > dds.CONTACT_N)
    dds.check_hold(f"{name}, wooden_box", peer, t0, 6.0, 30)
    holding = max(s for _, s in stds[-200:])
    check(f"holding: stddev of fz below {MAX_STD_N} N", holding < MAX_STD_N, f"at most {holding:.4f} N")
    # For 1 s among sim_robot's readings (the peer hears its own too: the
    # reading copied is the one before).
    pub = peer.node.create_publisher(BioTac, "biotac/readings", qos_profile_sensor_data)
    pressed, t_odd = copy.deepcopy(peer.latest), time.monotonic()
    for _ in range(100):
        m = copy.deepcopy(pressed)
        m.electrodes = [max(0, e - 1500) for e in m.electrodes]
        m.header.stamp = peer.node.get_clock().now().to_msg()
        pub.publish(m)
        peer.spin(0.01)
    odd = max((s for t, s in stds if t >= t_odd), default=0.0)
    check(f"readings outside the model: stddev of fz above {MAX_STD_N} N", odd > MAX_STD_N, f"{odd:.3f} N")
    stopped = peer.spin(10, lambda: any(name == "force_controller" and m.endswith(": out_of_range")
                                        for name, _, m in peer.logs))
    said = next((m for name, _, m in reversed(peer.logs) if name == "force_controller"), "")
    check("the controller's doubt stop: the task ends out_of_range", stopped, said[:120])
    peer.spin(5)
    last = max(abs(f) for _, f in peer.ft_stamped[-50:])
    check("retracted out of contact", last < dds.CONTACT_N, f"|fz| at most {last:.3f} N over the last 0.5 s")


def run(work, name, options, said):
    """The guarded move and the doubt stop on the model `name`; True when
    every check so far passed."""
    n = dds.Nodes("guarded_move.yaml", "wooden_box", estimator={"model_file": train(work, options)})
    peer = dds.Peer(n.domain)
    stds = []  # (receive time, std of fz)
    peer.node.create_subscription(WrenchEstimate, "biotac/wrench_estimate",
                                  lambda m: stds.append((time.monotonic(), m.stddev.force.z)), 100)
    ok = False
    try:
        runs = lambda: next((m for node, _, m in peer.logs if "model " in m and said in m), None)  # noqa: E731
        peer.spin(5, runs)
        check(f"the estimator runs the {name} model", runs() is not None,
              (runs() or "nothing on /rosout of it")[:120])
        touched = peer.spin(60, lambda: any(abs(f) > dds.CONTACT_N for _, f in peer.ft_stamped))
        check(f"{name}: contact", touched, f"{len(peer.forces)} ft_sensor/wrench messages")
        if touched:
            doubt(name, peer, stds)
        ok = summary() == 0
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)
    return ok


def main():
    work = tempfile.mkdtemp(prefix="tactile_force_doubt_")
    try:
        ok = all([run(work, *m) for m in MODELS])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
