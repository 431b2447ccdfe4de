"""What a peer on the DDS domain may name and cancel, over DDS: our nodes as
processes (test_over_dds.Nodes) and an rclpy peer.

- Calibration scene, `models_dir` a fresh folder for force_controller and
  wrench_estimator, beside a folder outside it: calibrate goals naming a
  model file outside (an absolute path), `../x.json`, a symlink to the
  outside folder, a symlinked file leading out, an existing file (no
  `overwrite`) and a session file outside are each aborted with
  `refused: ...` and its reason, no command but zero velocity sent from the
  goal to 0.5 s after its result, no file created or changed in either
  folder.
- The estimator's `model_file` set to /etc/hostname while running: refused
  (outside models_dir), the parameter and the model unchanged.
- A calibrate goal canceled while the pad presses the block: it ends
  `canceled` with the F/T force back under the contact threshold, no model
  written; the next calibrate goal ends `calibrated` (a cancel used to leave
  the pad pressed: "the pad was pressed during a rest").
- Guarded scene on the stuffed animal: a GuardedMove goal canceled while it
  regulates in contact ends `canceled` out of contact; the next goal holds.
- Bounded input (src/nodes/bounds.rs), guarded scene on the wooden box, the
  PA10's description published on /robot_description: a 50 MB description
  is refused and counted (`refused_oversized` on /diagnostics) while the
  controller goes on commanding at 100 Hz; a burst of 20 goals: the 5 of
  the rate refused by the safety envelope, the other 15 refused over the
  rate, each with its reason in its result, counted, the reason on
  /rosout; a burst of 30 parameter sets: those beyond the rate refused with it, and counted;
  the hold kept through all of it.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check and "N passed, N failed".
"""

import os
import re
import shutil
import sys
import tempfile
import time

from action_msgs.msg import GoalStatus
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.action import ActionClient
from std_msgs.msg import String
from tactile_force_msgs.action import Calibrate, GuardedMove
from checks import RESULTS, check, summary
from test_over_dds import CONTACT_N, Nodes, Peer, holding_on

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_goal(peer, client, goal, timeout, cancel_if=None):
    """Sends `goal`; with `cancel_if`, cancels it at the first feedback
    for which it is true. (result or None, that feedback or None)."""
    feedback = []
    sent = client.send_goal_async(goal, feedback_callback=lambda f: feedback.append(f.feedback))
    if not peer.spin(10, sent.done) or not sent.result().accepted:
        return None, None
    handle, at = sent.result(), None
    if cancel_if is not None and peer.spin(timeout, lambda: bool(feedback) and cancel_if(feedback[-1])):
        at = feedback[-1]
        handle.cancel_goal_async()
    result = handle.get_result_async()
    if not peer.spin(timeout, result.done):
        return None, at
    return result.result(), at


def files(*dirs):
    """Every entry under `dirs` (symlinks not followed), with its size and
    modification time."""
    out = {}
    for d in dirs:
        for root, subdirs, names in os.walk(d):
            for name in subdirs + names:
                path = os.path.join(root, name)
                st = os.lstat(path)
                out[path] = (st.st_size, st.st_mtime_ns)
    return out


def out_of_contact(peer, after):
    """The largest F/T force (N) received between `after` and 0.3 s on:
    under the contact threshold when the pad is clear."""
    peer.spin(0.3)
    recent = [f for t, f in peer.forces if t >= after]
    return max((sum(v * v for v in f) ** 0.5 for f in recent), default=float("nan"))


def refused_goals(n, peer, client, models, outside):
    """Each goal naming a path out of models_dir, or an existing file, is
    refused with its reason before the arm moves; nothing is written."""
    cases = [
        ("an absolute path outside", dict(model_file=os.path.join(outside, "x.json")), "is outside models_dir"),
        ("../x.json", dict(model_file="../x.json"), "`..` is not allowed"),
        ("a symlinked folder leading out", dict(model_file="out/x.json"), "leads out of models_dir through a symlink"),
        ("a symlinked file leading out", dict(model_file="link.json", overwrite=True),
         "leads out of models_dir through a symlink"),
        ("an existing file", dict(model_file="old.json"), "exists (the goal's overwrite: true replaces it)"),
        ("a session outside", dict(model_file="new.json", session_file=os.path.join(outside, "s.mcap")),
         "session_file"),
    ]
    for label, fields, why in cases:
        before = files(models, outside)
        t0 = time.monotonic()
        res, _ = run_goal(peer, client, Calibrate.Goal(**fields), 20)
        peer.spin(0.5)
        moved = sum(1 for t, zero in peer.commands if t > t0 and not zero)
        reason = res.result.reason if res else "no result"
        same = files(models, outside) == before
        check(f"calibrate goal naming {label}: refused before the arm moves, nothing written",
              res is not None and res.status == GoalStatus.STATUS_ABORTED and reason.startswith("refused:")
              and why in reason and moved == 0 and same,
              f"{reason!r}; {moved} non-zero commands; folders unchanged: {same}")
    with open(os.path.join(models, "old.json")) as f:
        check("the existing model file is untouched", f.read() == "old", "old.json still says 'old'")


def estimator_model_outside(n, peer):
    """model_file set to /etc/hostname: refused, the model kept."""
    before = peer.get_param("wrench_estimator", "model_file")
    since = len(n.log("wrench_estimator"))
    # The service found again if a loaded machine's discovery misses it once.
    for _ in range(3):
        ok, why = peer.set_param("wrench_estimator", "model_file", "/etc/hostname")
        if why not in ("no set_parameters service", "no answer"):
            break
    after = peer.get_param("wrench_estimator", "model_file")
    took = "estimating with it" in n.log("wrench_estimator")[since:]
    check("estimator model_file /etc/hostname: refused, its model kept",
          not ok and "is outside models_dir" in why and after == before and not took,
          f"{why[:110]!r}; model_file {after!r}")


def calibration_canceled_then_done(peer, client, models):
    """A calibration canceled while pressing ends out of contact; the next
    one succeeds."""
    pressing = lambda f: f.phase in ("regulate", "hold") and f.force_n > 0.3  # noqa: E731
    res, at = run_goal(peer, client, Calibrate.Goal(model_file="c1.json"), 120, cancel_if=pressing)
    t_end = time.monotonic()
    clear = out_of_contact(peer, t_end)
    reason = res.result.reason if res else "no result"
    check("calibrate goal canceled while pressing: ends canceled, out of contact, no model",
          at is not None and res is not None and res.status == GoalStatus.STATUS_CANCELED
          and reason.startswith("canceled") and clear < CONTACT_N
          and not os.path.exists(os.path.join(models, "c1.json")),
          f"canceled in {at.phase if at else None} at {at.force_n if at else 0:.2f} N; {reason[:90]!r}; "
          f"F/T {clear:.3f} N after")
    res, _ = run_goal(peer, client, Calibrate.Goal(model_file="c2.json"), 240)
    reason = res.result.reason if res else "no result"
    check("the next calibrate goal ends calibrated",
          res is not None and res.status == GoalStatus.STATUS_SUCCEEDED
          and (reason == "calibrated" or reason.startswith("calibrated; worse than the current model on "))
          and os.path.exists(os.path.join(models, "c2.json")),
          f"{reason[:120]!r}")


def calibration():
    tmp = tempfile.mkdtemp(prefix="tactile_force_wire_")
    models, outside = os.path.join(tmp, "models"), os.path.join(tmp, "outside")
    os.makedirs(models)
    os.makedirs(outside)
    with open(os.path.join(outside, "secret.json"), "w") as f:
        f.write("{}")
    os.symlink(outside, os.path.join(models, "out"))
    os.symlink(os.path.join(outside, "secret.json"), os.path.join(models, "link.json"))
    with open(os.path.join(models, "old.json"), "w") as f:
        f.write("old")
    where = {"models_dir": models}
    n = Nodes("calibrate.yaml", "calibration_block", sim={"sensor_unit": 2}, controller=where, estimator=where)
    peer = Peer(n.domain)
    client = ActionClient(peer.node, Calibrate, "force_controller/calibrate")
    ok = False
    try:
        if not client.wait_for_server(timeout_sec=10):
            check("calibrate action server", False, "force_controller/calibrate")
            return
        peer.spin(30, lambda: len(peer.commands) > 10)
        refused_goals(n, peer, client, models, outside)
        estimator_model_outside(n, peer)
        calibration_canceled_then_done(peer, client, models)
        ok = all(RESULTS)
    finally:
        client.destroy()
        peer.destroy()
        n.stop(keep_logs=not ok)
        shutil.rmtree(tmp)


def guarded():
    n = Nodes("guarded_move.yaml", "stuffed_animal")
    peer = Peer(n.domain)
    ok = False
    try:
        touched = peer.spin(60, lambda: any(abs(f) > CONTACT_N for _, f in peer.ft_stamped))
        if not touched or not peer.client.wait_for_server(timeout_sec=10):
            check("guarded: contact and action server", False, f"touched: {touched}")
            return
        away = GuardedMove.Goal(max_distance_m=0.01)
        away.direction.z = 1.0  # the pad faces -z
        run_goal(peer, peer.client, away, 20)
        in_contact = lambda f: f.phase == "regulate" and f.force_n > 0.3  # noqa: E731
        res, at = run_goal(peer, peer.client, GuardedMove.Goal(), 30, cancel_if=in_contact)
        clear = out_of_contact(peer, time.monotonic())
        reason = res.result.reason if res else "no result"
        check("guarded goal canceled in contact: ends canceled, out of contact",
              at is not None and res is not None and res.status == GoalStatus.STATUS_CANCELED
              and reason == "canceled" and clear < CONTACT_N,
              f"canceled in {at.phase if at else None} at {at.force_n if at else 0:.2f} N; {reason!r}; "
              f"F/T {clear:.3f} N after")
        res, _ = run_goal(peer, peer.client, GuardedMove.Goal(), 30)
        reason = res.result.reason if res else "no result"
        check("the next guarded goal holds", res is not None and res.status == GoalStatus.STATUS_SUCCEEDED
              and reason == "hold", reason)
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def big_description(peer, n):
    """50 MB on /robot_description: refused before it is decoded and
    counted by the controller, which goes on commanding; sim_robot, which
    has its arm, no longer reads the topic."""
    big = "<robot name='big'>" + " " * (50 << 20) + "</robot>"
    before = len(peer.commands)
    t0 = time.monotonic()
    peer.description.publish(String(data=big))
    counted = lambda: peer.diagnostics.get("force_controller", {}).get("refused_oversized") == "1"  # noqa: E731
    peer.spin(30, counted)
    wall = time.monotonic() - t0
    peer.spin(1.0)
    rate = (len(peer.commands) - before) / (time.monotonic() - t0)
    said = re.compile(r"refused /robot_description: a message of 524288\d\d bytes, over its bound of 10485760 bytes")
    logged = [exe for exe in ("force_controller", "sim_robot") if said.search(n.log(exe))]
    check("a 50 MB robot_description: refused, counted, the controller still commands",
          counted() and rate >= 90 and logged == ["force_controller"] and holding_on(peer),
          f"counted after {wall:.1f} s; {rate:.0f} commands per s meanwhile; refused in the log of {logged}")


def goal_burst(peer):
    """20 goals in a row, each sent as the last is answered: every one
    answered, the rate's 5 refused by the safety envelope, the rest refused
    over the rate (each with its reason in its result), counted, and said
    on /rosout."""
    t0, answers, reasons = time.monotonic(), [], []
    for _ in range(20):
        sent = peer.client.send_goal_async(GuardedMove.Goal(speed_mps=0.2))
        peer.spin(5, sent.done)
        answers.append(sent.result() if sent.done() else None)
        if answers[-1] is not None and answers[-1].accepted:
            result = answers[-1].get_result_async()
            peer.spin(5, result.done)
            if result.done():
                reasons.append(result.result().result.reason)
    wall = time.monotonic() - t0
    accepted = [h for h in answers if h is not None and h.accepted]
    over = sum(1 for r in reasons if r.startswith("refused: over the rate: at most 5 goals at once and 2 a second"))
    envelope = sum(1 for r in reasons if r.startswith("refused: parameter guarded.approach_speed_mps"))
    count = peer.diagnostic("force_controller", "refused_goals_over_rate")
    said = any(name == "force_controller" and "over the rate: at most 5 goals at once and 2 a second" in m
               for name, _, m in peer.logs)
    # The burst's 5, and one more for each half second the burst took.
    rate = len(reasons) == 20 and 5 <= envelope <= 5 + int(2 * wall) and over == 20 - envelope
    check("20 goals in a burst: the rate's 5 refused on their merits, the rest over the rate, each with its "
          "reason, counted and logged",
          rate and count == str(over) and said and holding_on(peer),
          f"in {wall:.2f} s: {len(accepted)} accepted, {len(reasons)} results: {envelope} refused by the "
          f"envelope, {over} over the rate; refused_goals_over_rate {count}; reason on /rosout: {said}")


def parameter_burst(peer):
    """30 parameter sets in a row: those beyond the rate refused with it
    and counted; the others answered on their own merits."""
    client = peer.node.create_client(SetParameters, "force_controller/set_parameters")
    client.wait_for_service(timeout_sec=10)
    value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="fast")
    request = SetParameters.Request(parameters=[Parameter(name="task", value=value)])
    t0, answers = time.monotonic(), []
    for _ in range(30):
        answer = client.call_async(request)
        peer.spin(5, answer.done)
        answers.append(answer.result().results[0].reason if answer.done() else "no answer")
    wall = time.monotonic() - t0
    peer.node.destroy_client(client)
    over = sum(1 for r in answers if "refused: over the rate: at most 10 parameter sets at once" in r)
    merits = sum(1 for r in answers if "expected guarded, guided or calibrate" in r)
    count = peer.diagnostic("force_controller", "refused_parameter_sets_over_rate")
    check("30 parameter sets in a burst: those beyond the rate refused with it and counted",
          over >= 15 and over + merits == 30 and count == str(over),
          f"in {wall:.2f} s: {merits} refused on their merits (unknown task), {over} over the rate; "
          f"refused_parameter_sets_over_rate {count}")


def bounded():
    n = Nodes("guarded_move.yaml", "wooden_box", description_topic=True)
    peer = Peer(n.domain)
    ok = False
    try:
        peer.publish_description("pa10")
        touched = peer.spin(60, lambda: any(abs(f) > CONTACT_N for _, f in peer.ft_stamped))
        if not touched or not peer.client.wait_for_server(timeout_sec=10) or not holding_on(peer, 8):
            check("bounded: the hold and the action server", False, f"touched: {touched}")
            return
        big_description(peer, n)
        goal_burst(peer)
        parameter_burst(peer)
        ok = all(RESULTS)
    finally:
        peer.destroy()
        n.stop(keep_logs=not ok)


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    calibration()
    guarded()
    bounded()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
