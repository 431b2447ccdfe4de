"""config/sros2/tactile_force.policy.xml against the endpoints the nodes
create: each node runs as the launch files start it (the guided scene on
the UR5, its robot description on /robot_description, so that every
subscription is made; biotac_driver on the serial emulator's
pseudo-terminal), and an rclpy peer lists, per node, the topics it
publishes and subscribes, the services it serves and calls. Every endpoint
must be allowed by the node's profile, and every permission of a profile
used, except the inputs another configuration takes (CONDITIONAL).

DDS security itself is not exercised here: the Fast DDS of the PyPI Jazzy
wheels is built without its security plugins (its library holds no
`DDS:Auth:PKI-DH`), so `ROS_SECURITY_ENABLE=true` cannot run on this
machine; the test says so when that is the case.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import glob
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

import test_over_dds as dds
from checks import check, summary

POLICY = os.path.join(dds.REPO, "config", "sros2", "tactile_force.policy.xml")
# Permissions a node uses only in another configuration than the test's
# (the estimator's other inputs), or only for a while (sim_robot's finger
# listens for the first estimate, then unsubscribes).
CONDITIONAL = {
    "wrench_estimator": {("subscribe", "/rh/tactile"), ("subscribe", "/camera/image")},
    "sim_robot": {("subscribe", "/biotac/wrench")},
}
ACTION_SERVICES = ("send_goal", "cancel_goal", "get_result")
ACTION_TOPICS = ("feedback", "status")


def absolute(name, node):
    """A policy name as the graph lists it: `~/x` -> `/node/x`, `x` -> `/x`."""
    return f"/{node}/{name[2:]}" if name.startswith("~/") else f"/{name.lstrip('/')}"


def allowed(profile):
    """A profile's permissions as {(kind, name)}: kind is publish,
    subscribe, reply (serves) or request (calls); an action it executes is
    its three services and two topics."""
    node, out = profile.get("node"), set()
    for group in profile:
        for kind, value in group.attrib.items():
            if value != "ALLOW":
                continue
            for item in group:
                name = absolute(item.text.strip(), node)
                if group.tag == "actions" and kind == "execute":
                    out |= {("reply", f"{name}/_action/{s}") for s in ACTION_SERVICES}
                    out |= {("publish", f"{name}/_action/{t}") for t in ACTION_TOPICS}
                else:
                    out.add((kind, name))
    return out


def endpoints(peer, node):
    """What `node` has on the graph, as {(kind, name)}."""
    listed = {
        "publish": peer.get_publisher_names_and_types_by_node,
        "subscribe": peer.get_subscriber_names_and_types_by_node,
        "reply": peer.get_service_names_and_types_by_node,
        "request": peer.get_client_names_and_types_by_node,
    }
    return {(kind, name) for kind, by_node in listed.items() for name, _ in by_node(node, "/")}


def compare(peer, profiles, node):
    """Checks one node's endpoints against its profile."""
    have, may = endpoints(peer, node), profiles[node]
    extra = sorted(have - may)
    check(f"{node}: every endpoint allowed by its profile", not extra and bool(have),
          f"{len(have)} endpoints; not allowed: {extra}")
    unused = sorted(may - have - CONDITIONAL.get(node, set()))
    check(f"{node}: every permission used", not unused, f"{len(may)} permissions; unused: {unused}")


def security_plugins():
    """True when the ROS installation's Fast DDS has its security plugins."""
    libs = glob.glob(os.path.join(os.environ.get("VIRTUAL_ENV", "/opt/ros/jazzy"), "lib", "libfastrtps.so*"))
    return any(b"DDS:Auth:PKI-DH" in open(lib, "rb").read() for lib in libs)


def spin(node, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)


def scene(profiles):
    """The guided scene's nodes on the UR5, its description by topic."""
    n = dds.Nodes("guided_move.yaml", "fingertip", robot="ur5", description_topic=True)
    rclpy.init(domain_id=n.domain)
    peer = rclpy.create_node("policy_check")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    peer.create_publisher(String, "/robot_description", latched).publish(String(data=dds.urdf("ur5")))
    try:
        spin(peer, 8.0)
        for node in ("wrench_estimator", "force_controller", "sim_robot"):
            compare(peer, profiles, node)
    finally:
        peer.destroy_node()
        rclpy.shutdown()
        n.stop(keep_logs=False)


def driver(profiles):
    """biotac_driver on the emulator's pseudo-terminal."""
    emulator = subprocess.Popen(["tactile_force", "biotac-emulator", "--pty"],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    port = emulator.stdout.readline().split()[-1]
    n = dds.Nodes("guarded_move.yaml", "wooden_box", port=port, only=("biotac_driver",))
    rclpy.init(domain_id=n.domain)
    peer = rclpy.create_node("policy_check")
    try:
        spin(peer, 5.0)
        compare(peer, profiles, "biotac_driver")
    finally:
        peer.destroy_node()
        rclpy.shutdown()
        n.stop(keep_logs=False)
        emulator.terminate()
        emulator.wait(timeout=10)


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(dds.REPO, "target", "ros-test-cache"))
    root = ET.parse(POLICY).getroot()
    profiles = {p.get("node"): allowed(p) for p in root.iter("profile")}
    enclaves = {e.get("path") for e in root.iter("enclave")}
    check("one enclave a node", enclaves == {f"/tactile_force/{n}" for n in profiles} and len(profiles) == 4,
          f"{sorted(enclaves)}")
    if not security_plugins():
        print("note: this Fast DDS has no security plugins (no DDS:Auth:PKI-DH in libfastrtps): "
              "the policy is checked against the graph, not enforced", flush=True)
    scene(profiles)
    driver(profiles)
    return summary()


if __name__ == "__main__":
    sys.exit(main())
