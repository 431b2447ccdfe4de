"""What an operator looks at, over DDS: config/tactile_force.rviz and
config/foxglove_layout.json name only topics and frames the nodes publish,
and force_controller's markers draw the estimate they came with.

The guarded scene on the UR5, started as the launch files start it, its
description on /robot_description from the peer (as robot_state_publisher
would send it); an rclpy peer reads the graph, /tf_static, the estimates
and the markers.

- Every topic a display of the RViz configuration or a panel of the
  Foxglove layout reads (the layout's user script: its input) is on the
  graph with the type that display reads: published by our nodes, or, for
  /robot_description (robot_state_publisher's), subscribed by them with
  that type.
- The frames: the TF display's frame (`biotac`) is on /tf_static, its parent
  the robot file's tip link, a link of the URDF whose root is the fixed
  frame the launch files give rviz2 (`-f`, tactile_force_nodes.viewers());
  the configuration's own Fixed Frame is the PA10's and the UR5's root.
- The launch files: `rviz` declared, default false; viewers() starts rviz2
  on the shipped configuration, and robot_state_publisher in simulation.
- force_controller/markers: ids 0, 1, 2 as ARROW, SPHERE, TEXT_VIEW_FACING
  in the estimate's frame, every number finite; each set has the stamp of
  an estimate the peer received, and draws it: the arrow to (0, 0, fz *
  0.05 m/N) (fx, fy not estimated: 0), the ellipsoid there, 2 sigma * 0.05
  m/N along z and flat (0.5 mm) across, the text's `fz` line with the
  estimate's numbers; about 20 sets a second, their stamps at least 49 ms
  apart; the phases on the text are those /diagnostics reports, hold among
  them once the move holds.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import ast
import json
import math
import os
import re
import sys

import yaml
from rclpy.qos import qos_profile_sensor_data
from tactile_force_msgs.msg import WrenchEstimate
from visualization_msgs.msg import Marker, MarkerArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, key, summary  # noqa: E402
from test_over_dds import REPO, Nodes, Peer, urdf  # noqa: E402
from tactile_force_nodes import RVIZ_CONFIG, urdf_root, viewers  # noqa: E402

CONFIG = os.path.join(REPO, "config")
METRES_PER_NEWTON = 0.05  # src/nodes/markers.rs
FLAT_M = 5e-4
MARKERS = "/force_controller/markers"
# The type each display reads.
RVIZ_TYPES = {
    "rviz_default_plugins/Wrench": "geometry_msgs/msg/WrenchStamped",
    "rviz_default_plugins/MarkerArray": "visualization_msgs/msg/MarkerArray",
    "rviz_default_plugins/RobotModel": "std_msgs/msg/String",
}
# What the layout's panels read, by topic.
FOXGLOVE_TYPES = {
    "/biotac/wrench_estimate": "tactile_force_msgs/msg/WrenchEstimate",
    MARKERS: "visualization_msgs/msg/MarkerArray",
    "/robot_description": "std_msgs/msg/String",
}
OURS = {"wrench_estimator", "force_controller", "sim_robot"}
# The guarded move's phases (src/control/guarded.rs, src/control/mod.rs).
GUARDED_PHASES = {"approach", "regulate", "hold", "retract", "stopped"}


def rviz_displays(displays):
    for d in displays:
        yield d
        yield from rviz_displays(d.get("Displays", []))


def rviz_config():
    """(topics {name: type}, TF display frames, Fixed Frame) of the RViz
    configuration."""
    with open(os.path.join(CONFIG, RVIZ_CONFIG)) as f:
        manager = yaml.safe_load(f)["Visualization Manager"]
    topics, frames = {}, []
    for d in rviz_displays(manager["Displays"]):
        source = d.get("Topic") or d.get("Description Topic")
        if source is not None:
            topics[source["Value"]] = RVIZ_TYPES[d["Class"]]
        if d["Class"] == "rviz_default_plugins/TF":
            frames = [k for k, v in d["Frames"].items() if isinstance(v, dict) and v.get("Value")]
    return topics, frames, manager["Global Options"]["Fixed Frame"]


def foxglove_topics():
    """{topic: type} of what the layout's panels and user scripts read
    (a script's output, /studio_script/..., is the layout's own)."""
    with open(os.path.join(CONFIG, "foxglove_layout.json")) as f:
        layout = json.load(f)
    read = set()
    for panel_id, panel in layout["configById"].items():
        read |= set(panel.get("topics", {}))
        read |= {layer["topic"] for layer in panel.get("layers", {}).values() if "topic" in layer}
        read |= {p["value"] for p in panel.get("paths", [])}
        if "topicPath" in panel:
            read.add(panel["topicPath"])
    for script in layout["userNodes"].values():
        inputs = re.search(r"export const inputs = (\[.*?\]);", script["sourceCode"]).group(1)
        read |= set(json.loads(inputs))
    topics = {re.match(r"(/[\w/]+)", path).group(1) for path in read}
    return {t: FOXGLOVE_TYPES[t] for t in topics if not t.startswith("/studio_script/")}


def graph_check(peer, topics, label):
    """Each topic published by our nodes with its type (/robot_description:
    subscribed by them with it)."""
    bad = []
    for topic, want in sorted(topics.items()):
        lookup = peer.node.get_subscriptions_info_by_topic if topic == "/robot_description" \
            else peer.node.get_publishers_info_by_topic
        ends = [(e.node_name, e.topic_type) for e in lookup(topic) if e.node_name in OURS]
        if not ends or any(t != want for _, t in ends):
            bad.append(f"{topic}: {ends or 'none of ours'} (want {want})")
    check(f"{label}: every topic on the graph with the type its display reads", not bad,
          f"{sorted(topics)}; {bad}")


def launch_checks():
    """The `rviz` argument and the processes it adds."""
    with open(os.path.join(REPO, "launch", "guarded_move_launch_common.py")) as f:
        tree = ast.parse(f.read())
    declared = {c.args[0].value: {k.arg: k.value.value for k in c.keywords if isinstance(k.value, ast.Constant)}
                for c in ast.walk(tree) if isinstance(c, ast.Call) and getattr(c.func, "id", "") ==
                "DeclareLaunchArgument"}
    sim = viewers(CONFIG, urdf("ur5"), state_publisher=True)
    real = viewers(CONFIG, urdf("panda"), state_publisher=False)
    mine = viewers(CONFIG, urdf("ur5"), base_link="shoulder_link", state_publisher=False)
    rviz_args = ["-d", os.path.join(CONFIG, RVIZ_CONFIG), "-f"]
    ok = (declared.get("rviz", {}).get("default_value") == "false"
          and [p[:2] for p in sim] == [("robot_state_publisher", "robot_state_publisher"), ("rviz2", "rviz2")]
          and sim[0][3]["robot_description"] == urdf("ur5") and sim[1][2] == rviz_args + ["base_link"]
          and [p[:3] for p in real] == [("rviz2", "rviz2", rviz_args + ["panda_link0"])]
          and mine[0][2][-1] == "shoulder_link" and os.path.isfile(rviz_args[1]))
    check("launch: rviz (default false) adds rviz2 on the shipped configuration, fixed frame the chain's base, "
          "and robot_state_publisher in simulation", ok,
          f"rviz: {declared.get('rviz')}; sim: {[p[:3] for p in sim]}; real arm: {[p[:3] for p in real]}")


def frame_checks(peer, frames, fixed):
    """The TF display's frames on /tf_static, each in a link of the URDF
    whose root is the fixed frame rviz2 is given."""
    peer.spin(5, lambda: peer.static_tf)
    placed = {t.child_frame_id: t.header.frame_id for m in peer.static_tf for t in m}
    with open(os.path.join(CONFIG, "ur5.yaml")) as f:
        tip = yaml.safe_load(f)["/**"]["ros__parameters"]["robot"]["tip_link"]
    links = set(re.findall(r'<link name="([^"]+)"', urdf("ur5")))
    launched = viewers(CONFIG, urdf("ur5"), state_publisher=False)[0][2][-1]
    check("frames: the TF display's frames on /tf_static, in the tip link of a URDF rooted at rviz2's -f",
          frames and all(placed.get(f) == tip for f in frames) and tip in links
          and launched == urdf_root(urdf("ur5")),
          f"TF display {frames}; /tf_static {placed}; tip {tip}; -f {launched}")
    roots = {r: urdf_root(urdf(r)) for r in ("pa10", "ur5", "panda")}
    check("frames: the configuration's Fixed Frame is the PA10's and the UR5's root (the Panda's by -f)",
          fixed == roots["pa10"] == roots["ur5"], f"Fixed Frame {fixed}; roots {roots}")
    # A description generated from a ros2_control xacro: joints that name
    # no links, inside <transmission> and <ros2_control>.
    control = ('<transmission name="t"><joint name="shoulder_pan_joint"/></transmission>'
               '<ros2_control name="arm" type="system"><joint name="shoulder_pan_joint">'
               '<command_interface name="velocity"/></joint></ros2_control></robot>')
    with_control = urdf("ur5").replace("</robot>", control)
    root = urdf_root(with_control)
    check("frames: the root of a URDF with <transmission> and <ros2_control> blocks", root == roots["ur5"], root)


class Seen:
    """Estimates by stamp, marker sets in order, phases on /diagnostics."""

    def __init__(self, peer):
        self.estimates, self.sets, self.phases = {}, [], set()
        peer.node.create_subscription(WrenchEstimate, "biotac/wrench_estimate",
                                      lambda m: self.estimates.__setitem__(key(m.header.stamp), m),
                                      qos_profile_sensor_data)
        peer.node.create_subscription(MarkerArray, MARKERS, self.sets.append, 10)
        self.peer = peer

    def phase(self):
        p = self.peer.diagnostics.get("force_controller", {}).get("phase")
        if p is not None:
            self.phases.add(p)


def finite(m):
    p, q, s, c = m.pose.position, m.pose.orientation, m.scale, m.color
    values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w, s.x, s.y, s.z, c.r, c.g, c.b, c.a]
    values += [v for pt in m.points for v in (pt.x, pt.y, pt.z)]
    return all(math.isfinite(v) for v in values)


def drawn(m_set, e):
    """What is wrong with one set of markers against its estimate `e`."""
    by_id = {m.id: m for m in m_set.markers}
    arrow, band, text = by_id.get(0), by_id.get(1), by_id.get(2)
    if sorted(by_id) != [0, 1, 2] or not all(finite(m) for m in m_set.markers):
        return f"ids {sorted(by_id)}, finite {[finite(m) for m in m_set.markers]}"
    if (arrow.type, band.type, text.type) != (Marker.ARROW, Marker.SPHERE, Marker.TEXT_VIEW_FACING):
        return f"types {arrow.type}, {band.type}, {text.type}"
    frames = {m.header.frame_id for m in m_set.markers}
    if frames != {e.header.frame_id}:
        return f"frames {frames}, the estimate's {e.header.frame_id}"
    fz, sd = e.wrench.force.z, e.stddev.force.z
    tip = arrow.points[1]
    want_tip = (0.0, 0.0, fz * METRES_PER_NEWTON)
    if any(abs(a - b) > 1e-12 for a, b in zip((tip.x, tip.y, tip.z), want_tip)):
        return f"arrow to {(tip.x, tip.y, tip.z)}, want {want_tip}"
    c, s = band.pose.position, band.scale
    if (c.x, c.y, c.z) != (tip.x, tip.y, tip.z) or (s.x, s.y) != (FLAT_M, FLAT_M) \
            or abs(s.z - 2 * sd * METRES_PER_NEWTON) > 1e-15:
        return f"band at {(c.x, c.y, c.z)} scale {(s.x, s.y, s.z)}, sigma {sd}"
    line = f"fz {fz:+.3f} N +- {sd:.3f}"
    if text.text.split("\n")[1:] != [line]:
        return f"text {text.text!r}, want the line {line!r}"
    return None


def marker_checks(seen, seconds):
    sets = seen.sets
    by_stamp = [(s, seen.estimates.get(key(s.markers[0].header.stamp))) for s in sets if s.markers]
    wrong = [(key(s.markers[0].header.stamp), drawn(s, e) if e else "no estimate of its stamp")
             for s, e in by_stamp]
    wrong = [w for w in wrong if w[1]]
    check("markers: ids 0-2 ARROW, SPHERE, TEXT, finite, each drawing the estimate of its stamp "
          "(arrow fz x 0.05 m/N, band 2 sigma x 0.05 m/N, text)", sets and not wrong,
          f"{len(sets)} sets, {len(wrong)} wrong: {wrong[:3]}")
    stamps = [key(s.markers[0].header.stamp) for s in sets if s.markers]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    rate = len(sets) / seconds
    check("markers: about 20 sets a second, their stamps at least 49 ms apart",
          15 <= rate <= 21 and gaps and min(gaps) >= 0.049 - 1e-6,
          f"{rate:.1f} sets/s, stamps {min(gaps, default=math.nan) * 1e3:.1f} to "
          f"{max(gaps, default=math.nan) * 1e3:.1f} ms apart")
    texts = [m.text.split("\n")[0] for s in sets for m in s.markers if m.id == 2]
    shown = set(texts)
    latest = seen.peer.diagnostics.get("force_controller", {}).get("phase")
    check("markers: the text's phases are the guarded move's, hold as /diagnostics says once it holds",
          shown and shown <= GUARDED_PHASES and "hold" in shown & seen.phases and texts[-1] == latest,
          f"text: {sorted(shown)}, the last {texts[-1:]}; /diagnostics: {sorted(seen.phases)}, the last {latest}")
    sizes = [m.scale.z for s in sets for m in s.markers if m.id == 1]
    return min(sizes, default=math.nan), max(sizes, default=math.nan)


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    topics, frames, fixed = rviz_config()
    launch_checks()
    n = Nodes("guarded_move.yaml", "wooden_box", robot="ur5", description_topic=True)
    peer = Peer(n.domain)
    seen = Seen(peer)
    ok = False
    try:
        peer.publish_description("ur5")
        peer.spin(20, lambda: len(seen.sets) > 20)
        graph_check(peer, topics, "RViz")
        graph_check(peer, foxglove_topics(), "Foxglove")
        frame_checks(peer, frames, fixed)
        # The approach, contact and hold, drawn: the sets of 12 s counted.
        seen.sets.clear()
        start = len(seen.estimates)
        for _ in range(120):
            peer.spin(0.1)
            seen.phase()
        smallest, largest = marker_checks(seen, 12.0)
        print(f"   {len(seen.estimates) - start} estimates; the band along z {smallest * 1e3:.3f} to "
              f"{largest * 1e3:.3f} mm", flush=True)
        ok = summary() == 0
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
