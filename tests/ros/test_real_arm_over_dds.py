"""A real arm's first day, over DDS: our executables as separate processes
(launch/tactile_force_nodes.py's node list) and an independent rclpy peer.
sim_robot holds the last command it got, as ros2_control's forward command
controllers do (`command_timeout_s` 0), unless a check says otherwise.

- Every way out stops the arm: SIGTERM, SIGINT, and a panic injected in the
  control loop (test-only: TACTILE_FORCE_INJECT_PANIC=control, then
  SIGUSR1), each 0.3 s into a 10 mm/s GuardedMove approach to the wooden
  box (`autostart` false, as on a real arm), and SIGTERM once during the
  guided move (then sim_robot's SIGINT and the estimator's SIGTERM end
  them with code 0 within 2 s): the last command on velocity_controller/commands and on
  twist_commands is all zeros, sent after the signal and within 50 ms of it;
  the joints move no more than 1e-4 rad from 0.5 s after the signal to 3 s
  after it; the F/T force stays under 1.1 N; the goal ends aborted with
  `stopped: SIGTERM` (SIGINT, panic); the process exits within 2 s, with
  code 0 for the signals (1 for the panic).
- The arm side: with `command_timeout_s` 0.2, a force_controller killed with
  SIGKILL (it cannot act) leaves an arm that stops by its own timeout.
- force_controller/stop (std_srvs/Trigger) during an approach, a hold and
  the guided move: answered, and a zero on both outputs, within one period
  (10 ms); the approach's goal ends aborted `stopped: service`; then a new
  goal holds, a `task` set guides again.
- Lifecycle, as `ros2 lifecycle` calls it (get_state, get_available_states,
  get_available_transitions, change_state by the transition's id and
  label; ~/transition_event): force_controller started `unconfigured`: no
  command, a goal refused with the reason; a parameter set taken for the
  next configure, a start-only one refused; configure -> inactive: a goal
  still refused, nothing commanded; activate -> a goal approaches;
  deactivate during it: the arm stopped as on a signal, the goal aborted
  `stopped: deactivated`; activate -> a goal holds; deactivate, cleanup,
  shutdown -> finalized. biotac_driver on the emulator's pseudo-terminal,
  started `inactive`: its link up (/diagnostics) but no reading published;
  activate -> readings at 100 Hz; deactivate -> none; cleanup closes the
  link; SIGINT ends it with code 0.
- Any driver heard: the F/T wrench relayed with SensorDataQoS (best
  effort) feeds a full calibration (it ends `calibrated`, naming any axis
  where the new model is worse); the estimate
  relayed best effort feeds a guarded hold (overshoot <= 0.1 N,
  steady-state error <= 0.05 N, sd <= 0.02 N); with no estimator, the
  silent `biotac/wrench_estimate` is named on /diagnostics within 5 s, with "no
  publisher", then with a publisher that sends nothing.
- Frames: the F/T wrench relayed in `ft_sensor_link`, a frame nobody
  declared: the calibration ends aborted naming both frames, said on
  /diagnostics; an estimator publishing in `tool0`: the guarded goal ends
  aborted naming both frames, and nothing moves.

Run by tests/ros/run.sh (after scripts/ros2-jazzy.sh). Prints one line per
check, the figures, and "N passed, N failed".
"""

import contextlib
import os
import signal
import subprocess
import sys
import time

from rclpy.action import ActionClient
from rclpy.qos import qos_profile_sensor_data
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped, WrenchStamped
from lifecycle_msgs.msg import Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetAvailableStates, GetAvailableTransitions, GetState
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from tactile_force_msgs.action import Calibrate, GuardedMove
from tactile_force_msgs.msg import BioTac, WrenchEstimate

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import RESULTS, check, summary  # noqa: E402
from test_over_dds import REPO, Nodes, Peer, check_hold, CONTACT_N  # noqa: E402

# The approach's time before a signal, the bound on the zero's delay after
# it, on the joints' motion once stopped and on the force.
INTO_APPROACH_S = 0.3
ZERO_WITHIN_S = 0.05
STILL_RAD = 1e-4
FORCE_MAX_N = 1.1
EXIT_WITHIN_S = 2.0


class Arm(Peer):
    """The peer, also watching twist_commands and the joints."""

    def __init__(self, domain):
        super().__init__(domain)
        self.twists = []  # (receive time, all zero)
        self.joints = []  # (receive time, positions)
        self.clients = {}  # service name -> its client, made once
        self.node.create_subscription(TwistStamped, "twist_commands", self._on_twist, 100)
        self.node.create_subscription(JointState, "joint_states", self._on_joints, 100)

    def _on_twist(self, m):
        v = (m.twist.linear.x, m.twist.linear.y, m.twist.linear.z,
             m.twist.angular.x, m.twist.angular.y, m.twist.angular.z)
        self.twists.append((time.monotonic(), all(x == 0.0 for x in v)))

    def _on_joints(self, m):
        self.joints.append((time.monotonic(), list(m.position)))

    def position_at(self, t):
        """The joint positions last received before monotonic time t."""
        before = [q for at, q in self.joints if at <= t]
        return before[-1] if before else None

    def service(self, srv, name):
        """The client of service `name`, made once: a call measured later
        goes over a connection discovery has already made, as an operator's
        tool's does once it has found the node (discovery's own delay is the
        graph's, not the node's)."""
        if name not in self.clients:
            self.clients[name] = self.node.create_client(srv, name)
        return self.clients[name]

    def call(self, srv, name, request, timeout=10.0):
        """Calls service `name`; (response or None, when it was sent), the
        answer's delay in `self.answered_in`."""
        client = self.service(srv, name)
        if not client.wait_for_service(timeout_sec=timeout):
            return None, None
        t = time.monotonic()
        future = client.call_async(request)
        done = self.spin(timeout, future.done)
        self.answered_in = time.monotonic() - t
        return (future.result() if done else None), t

    def send(self, goal):
        """Sends a goal; its result future, or None."""
        future = self.client.send_goal_async(goal)
        if not self.spin(10, future.done) or not future.result().accepted:
            return None
        return future.result().get_result_async()


@contextlib.contextmanager
def scenario(*args, **kwargs):
    """The nodes of `Nodes(*args, **kwargs)` and an `Arm` peer on their
    domain; both ended after, the logs kept when a check failed."""
    n = Nodes(*args, **kwargs)
    arm = Arm(n.domain)
    ok = False
    try:
        yield n, arm
        ok = all(RESULTS)
    finally:
        arm.destroy()
        n.stop(keep_logs=not ok)


def stop_figures(arm, t_sig):
    """What the commands did after the signal at t_sig: for each output,
    (the first zero's delay, the last command zero, any non-zero after the
    first zero)."""
    out = {}
    for name, sent in (("joints", arm.commands), ("twist", arm.twists)):
        after = [(t, zero) for t, zero in sent if t >= t_sig]
        first = next((t for t, zero in after if zero), None)
        out[name] = (None if first is None else first - t_sig,
                     bool(after) and after[-1][1],
                     any(not zero for t, zero in after if first is not None and t > first))
    return out


def check_stopped(label, n, arm, t_sig, code, result, reason):
    """The checks of one way out at t_sig (monotonic)."""
    exited_at = None
    p = n.procs["force_controller"]
    while time.monotonic() - t_sig < EXIT_WITHIN_S + 1.0 and exited_at is None:
        arm.spin(0.02)
        if p.poll() is not None:
            exited_at = time.monotonic()
    arm.spin(max(0.0, t_sig + 3.0 - time.monotonic()))
    figures = stop_figures(arm, t_sig)
    ok = all(delay is not None and delay <= ZERO_WITHIN_S and last and not later
             for delay, last, later in figures.values())
    detail = "; ".join(
        f"{name}: first zero {'none' if d is None else f'{1e3 * d:.1f} ms'} after, last zero {last}, "
        f"non-zero after it {later}" for name, (d, last, later) in figures.items())
    check(f"{label}: the last command on both outputs is zero, within 50 ms", ok, detail)
    q0, q1 = arm.position_at(t_sig + 0.5), arm.position_at(t_sig + 3.0)
    moved = max(abs(a - b) for a, b in zip(q0, q1)) if q0 and q1 else float("inf")
    check(f"{label}: the arm stays where it stopped", moved <= STILL_RAD,
          f"{moved:.2e} rad from 0.5 s to 3 s after")
    peak = max((abs(f[2]) for t, f in arm.forces if t >= t_sig), default=0.0)
    check(f"{label}: the F/T force stays under {FORCE_MAX_N} N", peak < FORCE_MAX_N,
          f"peak {peak:.3f} N after")
    took = None if exited_at is None else exited_at - t_sig
    check(f"{label}: the process exits within {EXIT_WITHIN_S} s, code {code}",
          took is not None and took <= EXIT_WITHIN_S and p.returncode == code,
          "still running" if took is None else f"{took:.2f} s, code {p.returncode}")
    if result is not None:
        done = arm.spin(2, result.done)
        r = result.result() if done else None
        check(f"{label}: the goal ends aborted, {reason!r}",
              r is not None and r.status == GoalStatus.STATUS_ABORTED and r.result.reason == reason,
              "no result" if r is None else f"status {r.status}, reason {r.result.reason!r}")
    return peak


def approach_then(n, arm, act):
    """A GuardedMove goal at 10 mm/s toward the box; `act()` 0.3 s after its
    first moving command; the time it acted and the goal's result future."""
    if not arm.client.wait_for_server(timeout_sec=10):
        check("approach: action server", False, "force_controller/guarded_move")
        return None, None
    arm.commands.clear()
    result = arm.send(GuardedMove.Goal(speed_mps=0.01))
    moving = arm.spin(10, lambda: any(not zero for _, zero in arm.commands))
    if result is None or not moving:
        check("approach: the goal moves the arm", False, n.tail("force_controller"))
        return None, None
    arm.spin(INTO_APPROACH_S)
    t = time.monotonic()
    act()
    return t, result


def ways_out():
    """SIGTERM, SIGINT and an injected panic during the approach."""
    with scenario("guarded_move.yaml", "wooden_box", controller={"autostart": False}) as (n, arm):
        for label, sig, code, reason in (
                ("SIGTERM during the approach", signal.SIGTERM, 0, "stopped: SIGTERM"),
                ("SIGINT during the approach", signal.SIGINT, 0, "stopped: SIGINT"),
                ("a panic in the control loop", signal.SIGUSR1, 1, "stopped: panic")):
            if label != "SIGTERM during the approach":
                n.restart_fresh("sim_robot")
            panic = {"TACTILE_FORCE_INJECT_PANIC": "control"} if sig == signal.SIGUSR1 else {}
            n.restart_fresh("force_controller", env=panic)
            p = n.procs["force_controller"]
            t, result = approach_then(n, arm, lambda: p.send_signal(sig))
            if t is not None:
                check_stopped(label, n, arm, t, code, result, reason)


def during_guided():
    """SIGTERM while the arm follows the finger."""
    with scenario("guided_move.yaml", "fingertip") as (n, arm):
        pressed = arm.spin(90, lambda: any(abs(f[2]) > 0.5 for _, f in arm.forces))
        check("guided: the finger presses", pressed, f"{len(arm.forces)} F/T messages")
        if pressed:
            arm.spin(2.0)
            t = time.monotonic()
            n.procs["force_controller"].send_signal(signal.SIGTERM)
            # The finger goes on along its path against the still arm.
            check_stopped("SIGTERM during the guided move", n, arm, t, 0, None, None)
            ended = {}
            for exe, sig in (("sim_robot", signal.SIGINT), ("wrench_estimator", signal.SIGTERM)):
                p = n.procs[exe]
                p.send_signal(sig)
                try:
                    p.wait(timeout=EXIT_WITHIN_S)
                except subprocess.TimeoutExpired:
                    pass
                ended[exe] = p.returncode
            check("sim_robot on SIGINT, wrench_estimator on SIGTERM: each ends, code 0, within 2 s",
                  ended == {"sim_robot": 0, "wrench_estimator": 0}, f"{ended}")


def arm_side_timeout():
    """SIGKILL (nothing can act): an arm with a command timeout stops."""
    with scenario("guarded_move.yaml", "wooden_box", controller={"autostart": False},
                  sim={"command_timeout_s": 0.2}) as (n, arm):
        p = n.procs["force_controller"]
        t, result = approach_then(n, arm, p.kill)
        if t is not None:
            arm.spin(3.0)
            q0, q1 = arm.position_at(t + 0.5), arm.position_at(t + 3.0)
            moved = max(abs(a - b) for a, b in zip(q0, q1)) if q0 and q1 else float("inf")
            last_zero = bool(arm.commands) and arm.commands[-1][1]
            check("SIGKILL: no zero sent, the arm's own 0.2 s timeout stops it",
                  not last_zero and moved <= STILL_RAD,
                  f"last command zero: {last_zero}; {moved:.2e} rad from 0.5 s to 3 s after")


PERIOD_S = 0.01


def stop_by_service(arm, label, result=None):
    """Calls force_controller/stop: answered and a zero on both outputs
    within one period; a goal running ends `stopped: service`."""
    answer, t = arm.call(Trigger, "force_controller/stop", Trigger.Request())
    took = arm.answered_in
    arm.spin(0.5)
    figures = stop_figures(arm, t or 0.0)
    zeros = all(d is not None and d <= PERIOD_S and last and not later
                for d, last, later in figures.values())
    check(f"stop service, {label}: answered and a zero on both outputs within {PERIOD_S * 1e3:.0f} ms",
          answer is not None and answer.success and took <= PERIOD_S and zeros,
          "no answer" if answer is None else f"answered in {1e3 * took:.1f} ms ({answer.message!r}); "
          + "; ".join(f"{name}: first zero {'none' if d is None else f'{1e3 * d:.1f} ms'} after"
                      for name, (d, _, _) in figures.items()))
    if result is not None:
        done = arm.spin(2, result.done)
        r = result.result() if done else None
        check(f"stop service, {label}: the goal ends aborted 'stopped: service'",
              r is not None and r.status == GoalStatus.STATUS_ABORTED and r.result.reason == "stopped: service",
              "no result" if r is None else f"status {r.status}, reason {r.result.reason!r}")


def goal_holds(arm, label):
    """A GuardedMove goal ends holding."""
    result = arm.send(GuardedMove.Goal())
    done = result is not None and arm.spin(40, result.done)
    r = result.result() if done else None
    check(f"{label}: a new goal ends holding", r is not None and r.result.reason == "hold",
          "no result" if r is None else f"status {r.status}, reason {r.result.reason!r}")
    return r is not None and r.result.reason == "hold"


def stop_service():
    """force_controller/stop during an approach, a hold and the guided move."""
    with scenario("guarded_move.yaml", "wooden_box", controller={"autostart": False}) as (n, arm):
        arm.service(Trigger, "force_controller/stop")
        t, result = approach_then(n, arm, lambda: None)
        if t is not None:
            stop_by_service(arm, "approach", result)
            if goal_holds(arm, "after the stop"):
                arm.spin(1.0)
                stop_by_service(arm, "hold")
    with scenario("guided_move.yaml", "fingertip") as (n, arm):
        pressed = arm.spin(90, lambda: any(abs(f[2]) > 0.5 for _, f in arm.forces))
        arm.service(Trigger, "force_controller/stop")
        if pressed:
            arm.spin(2.0)
            stop_by_service(arm, "guided move")
            ok_set, why = arm.set_param("force_controller", "task", "guided")
            moving = arm.spin(5, lambda: arm.commands and not arm.commands[-1][1])
            check("stop service, guided move: a task set guides again", ok_set and moving,
                  why or f"moving again: {moving}")


class Lifecycle:
    """A managed node's services, called as `ros2 lifecycle` calls them."""

    def __init__(self, arm, node):
        self.arm, self.node = arm, node
        self.sent_at = None  # when the last change_state was sent
        self.events = []
        arm.node.create_subscription(TransitionEvent, f"{node}/transition_event",
                                     lambda m: self.events.append(m), 100)

    def state(self):
        r, _ = self.arm.call(GetState, f"{self.node}/get_state", GetState.Request())
        return None if r is None else r.current_state.label

    def transitions(self):
        r, _ = self.arm.call(GetAvailableTransitions, f"{self.node}/get_available_transitions",
                             GetAvailableTransitions.Request())
        return [] if r is None else [(d.transition.id, d.transition.label) for d in r.available_transitions]

    def set(self, label):
        """`ros2 lifecycle set NODE label`: the transition looked up among the
        available ones, then asked by id and label; success."""
        found = [(i, lbl) for i, lbl in self.transitions() if lbl == label]
        if not found:
            return False
        i, lbl = found[0]
        r, self.sent_at = self.arm.call(ChangeState, f"{self.node}/change_state",
                                        ChangeState.Request(transition=Transition(id=i, label=lbl)))
        return r is not None and r.success


def set_param(arm, node, name, value):
    """Sets a string or float parameter; (successful, reason)."""
    v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value) if isinstance(value, str) \
        else ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    r, _ = arm.call(SetParameters, f"{node}/set_parameters",
                    SetParameters.Request(parameters=[Parameter(name=name, value=v)]))
    return (False, "no answer") if r is None else (r.results[0].successful, r.results[0].reason)


def refused_goal(arm, label, words):
    result = arm.send(GuardedMove.Goal())
    done = result is not None and arm.spin(5, result.done)
    reason = result.result().result.reason if done else ""
    check(f"lifecycle: a goal while {label} is refused with the reason", words in reason, reason[:140])


def controller_lifecycle():
    with scenario("guarded_move.yaml", "wooden_box",
                  controller={"autostart": False, "start_state": "unconfigured"}) as (n, arm):
        lc = Lifecycle(arm, "force_controller")
        states, _ = arm.call(GetAvailableStates, "force_controller/get_available_states",
                             GetAvailableStates.Request())
        labels = [st.label for st in states.available_states] if states else []
        check("lifecycle: force_controller starts unconfigured, transitions as rcl's",
              lc.state() == "unconfigured" and lc.transitions() == [(1, "configure"), (5, "shutdown")]
              and {"unconfigured", "inactive", "active", "finalized"} <= set(labels),
              f"{lc.state()}, open {lc.transitions()}, states {labels}")
        if not arm.client.wait_for_server(timeout_sec=10):
            check("lifecycle: action server", False, "force_controller/guarded_move")
            return
        refused_goal(arm, "unconfigured", "the node is unconfigured (lifecycle)")
        taken, why = set_param(arm, "force_controller", "guarded.target_force_n", 0.8)
        start_only, why2 = set_param(arm, "force_controller", "command_interface", "twist")
        unknown, why3 = set_param(arm, "force_controller", "no_such_parameter", 1.0)
        check("lifecycle: while unconfigured a set is taken for configure, a start-only or unknown one refused",
              taken and not start_only and "read at process start only" in why2
              and not unknown and "not a parameter of this node" in why3, f"{why!r}; {why2!r}; {why3!r}")
        check("lifecycle: configure -> inactive", lc.set("configure") and lc.state() == "inactive",
              f"{lc.state()}")
        refused_goal(arm, "inactive", "the node is inactive (lifecycle)")
        moving = [z for _, z in arm.commands if not z]
        check("lifecycle: nothing commanded before activation", not moving, f"{len(arm.commands)} commands")
        check("lifecycle: activate -> active", lc.set("activate") and lc.state() == "active", f"{lc.state()}")
        t, result = approach_then(n, arm, lambda: lc.set("deactivate"))
        if t is not None:
            t = lc.sent_at
            figures = stop_figures(arm, t)
            zeros = all(d is not None and d <= ZERO_WITHIN_S and last and not later
                        for d, last, later in figures.values())
            arm.spin(max(0.0, t + 3.0 - time.monotonic()))
            q0, q1 = arm.position_at(t + 0.5), arm.position_at(t + 3.0)
            moved = max(abs(a - b) for a, b in zip(q0, q1)) if q0 and q1 else float("inf")
            done = arm.spin(2, result.done)
            reason = result.result().result.reason if done else None
            check("lifecycle: deactivate during the approach stops the arm, the goal aborted",
                  zeros and moved <= STILL_RAD and reason == "stopped: deactivated"
                  and not any(not z for at, z in arm.commands if at > t + ZERO_WITHIN_S),
                  f"{figures}, {moved:.2e} rad after, reason {reason!r}")
            check("lifecycle: activate again", lc.set("activate"), lc.state())
            if goal_holds(arm, "lifecycle, active again"):
                peak = max(abs(f[2]) for _, f in arm.forces[-100:])
                check("lifecycle: configure took guarded.target_force_n 0.8", abs(peak - 0.8) < 0.1,
                      f"holding {peak:.3f} N")
        steps = [lc.set(label) for label in ("deactivate", "cleanup", "configure", "shutdown")]
        arm.spin(0.5)
        check("lifecycle: deactivate, cleanup, configure, shutdown -> finalized, each on ~/transition_event",
              all(steps) and lc.state() == "finalized" and len(lc.events) == 2 * 8
              and lc.events[-1].goal_state.label == "finalized",
              f"{steps}, {lc.state()}, {len(lc.events)} events, the last "
              f"{lc.events[-1].start_state.label} -> {lc.events[-1].goal_state.label}" if lc.events else "none")


def driver_lifecycle():
    emulator = subprocess.Popen(["tactile_force", "biotac-emulator", "--pty", "--press-peak-n", "0"],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    port = emulator.stdout.readline().split()[-1]
    try:
        with scenario("guarded_move.yaml", "wooden_box", port=port, only=("biotac_driver",)) as (n, arm):
            n.specs["biotac_driver"][1]["start_state"] = "inactive"
            n.restart_fresh("biotac_driver")
            driver_states(n, arm)
    finally:
        emulator.terminate()
        emulator.wait(timeout=10)


def driver_states(n, arm):
    """biotac_driver started inactive: each state's readings, then SIGINT."""
    lc = Lifecycle(arm, "biotac_driver")
    got, links = [], []
    arm.node.create_subscription(BioTac, "biotac/readings", got.append, qos_profile_sensor_data)
    arm.node.create_subscription(DiagnosticArray, "/diagnostics",
                                 lambda m: links.extend(st.message for st in m.status), 10)
    up = arm.spin(10, lambda: any(m.startswith(("connected", "streaming")) for m in links))
    arm.spin(1.0)
    check("lifecycle: biotac_driver inactive, its link up, no reading published",
          lc.state() == "inactive" and up and not got, f"{lc.state()}, {len(got)} readings; {links[-1:]}")

    def rate():
        n0, t0 = len(got), time.monotonic()
        arm.spin(2.0)
        return (len(got) - n0) / (time.monotonic() - t0)
    active = lc.set("activate")
    arm.spin(1.0)
    r_active = rate()
    inactive = lc.set("deactivate")
    arm.spin(0.2)
    r_inactive = rate()
    check("lifecycle: active 100 Hz of readings, inactive none",
          active and inactive and 90 <= r_active <= 110 and r_inactive == 0.0,
          f"{r_active:.1f} /s active, {r_inactive:.1f} /s inactive")
    cleaned = lc.set("cleanup") and lc.state() == "unconfigured"
    check("lifecycle: cleanup closes the link", cleaned and "link closed" in n.log("biotac_driver"),
          n.tail("biotac_driver", 2))
    p = n.procs["biotac_driver"]
    t = time.monotonic()
    p.send_signal(signal.SIGINT)
    try:
        p.wait(timeout=EXIT_WITHIN_S)
    except subprocess.TimeoutExpired:
        pass
    check("biotac_driver: SIGINT ends it with code 0 within 2 s", p.returncode == 0,
          f"code {p.returncode} after {time.monotonic() - t:.2f} s")


class Relay:
    """Republishes `src` on `dst` with `qos` (a driver of another QoS), its
    frame_id replaced by `frame` when given."""

    def __init__(self, node, src, dst, qos, frame=None, kind=WrenchStamped):
        self.pub = node.create_publisher(kind, dst, qos)
        self.frame = frame
        node.create_subscription(kind, src, self._on, 100)

    def _on(self, m):
        if self.frame is not None:
            m.header.frame_id = self.frame
        self.pub.publish(m)


def calibrate(arm, label):
    """A calibration goal; its result (status, reason) or None."""
    client = ActionClient(arm.node, Calibrate, "force_controller/calibrate")
    try:
        if not client.wait_for_server(timeout_sec=10):
            return None
        sent = client.send_goal_async(Calibrate.Goal(model_file=f"{label}_{os.getpid()}.json", overwrite=True))
        arm.spin(10, sent.done)
        result = sent.result().get_result_async() if sent.done() and sent.result().accepted else None
        done = result is not None and arm.spin(240, result.done)
        return (result.result().status, result.result().result) if done else None
    finally:
        client.destroy()


def calibration_ft(frame):
    """A calibration on unit 2 fed by the F/T wrench relayed best effort,
    in `frame` (None: as sim_robot sends it)."""
    try:
        with scenario("calibrate.yaml", "calibration_block", sim={"sensor_unit": 2},
                      remaps={"sim_robot": {"ft_sensor/wrench": "ft_sensor/wrench_sim"}}) as (n, arm):
            Relay(arm.node, "ft_sensor/wrench_sim", "ft_sensor/wrench", qos_profile_sensor_data, frame)
            calibrated(arm, frame)
    finally:
        for f in os.listdir(os.environ["TACTILE_FORCE_CACHE"]):
            if f.startswith(("best_effort_", "wrong_frame_")):
                os.remove(os.path.join(os.environ["TACTILE_FORCE_CACHE"], f))


def calibrated(arm, frame):
    """The calibration's checks, the F/T wrench relayed in `frame`."""
    got = calibrate(arm, "best_effort" if frame is None else "wrong_frame")
    status, r = got if got else (None, None)
    if frame is None:
        check("QoS: a best-effort F/T relay feeds a full calibration",
              r is not None and status == GoalStatus.STATUS_SUCCEEDED
              and (r.reason == "calibrated"
                   or r.reason.startswith("calibrated; worse than the current model on ")),
              "no result" if r is None else f"status {status}, reason {r.reason!r}, {r.pushes} pushes")
    else:
        said = arm.diagnostic("force_controller", "frame_refused ft_sensor/wrench", timeout=3) or ""
        both = f'"{frame}"' in (r.reason if r else "") and '"biotac"' in (r.reason if r else "")
        check("frames: an F/T wrench in an undeclared frame ends the calibration, both named",
              r is not None and status == GoalStatus.STATUS_ABORTED and both and frame in said,
              "no result" if r is None else f"{r.reason!r}; /diagnostics: {said!r}")


def best_effort_estimate():
    """The estimate relayed best effort: the guarded move holds."""
    with scenario("guarded_move.yaml", "wooden_box",
                  remaps={"wrench_estimator": {"biotac/wrench_estimate": "biotac/wrench_estimate_reliable"}}) \
            as (n, arm):
        Relay(arm.node, "biotac/wrench_estimate_reliable", "biotac/wrench_estimate", qos_profile_sensor_data,
              kind=WrenchEstimate)
        touched = arm.spin(60, lambda: any(abs(f) > CONTACT_N for _, f in arm.ft_stamped))
        check("QoS: a best-effort estimate: contact", touched, f"{len(arm.ft_stamped)} F/T messages")
        if touched:
            t0 = next(t for t, f in arm.ft_stamped if abs(f) > CONTACT_N)
            check_hold("QoS: a best-effort estimate", arm, t0, 6.0, 30)


def silent_input():
    """No estimator: biotac/wrench_estimate named silent within 5 s, no
    publisher; then a publisher that sends nothing."""
    with scenario("guarded_move.yaml", "wooden_box", only=("sim_robot", "force_controller")) as (n, arm):
        t = time.monotonic()
        key = "silent biotac/wrench_estimate"
        named = arm.spin(5, lambda: key in arm.diagnostics.get("force_controller", {}))
        said = arm.diagnostics.get("force_controller", {}).get(key, "")
        check("silent input: biotac/wrench_estimate named on /diagnostics within 5 s, no publisher",
              named and said.endswith("no publisher"), f"after {time.monotonic() - t:.1f} s: {said!r}")
        arm.node.create_publisher(WrenchEstimate, "biotac/wrench_estimate", 10)
        quiet = arm.spin(5, lambda: arm.diagnostics.get("force_controller", {}).get(key, "").endswith(
            "1 publisher(s), none sending"))
        check("silent input: a publisher that sends nothing is said so", quiet,
              arm.diagnostics.get("force_controller", {}).get(key, ""))


def wrong_estimate_frame():
    """An estimator publishing in tool0: the goal is refused naming both."""
    with scenario("guarded_move.yaml", "wooden_box", controller={"autostart": False},
                  estimator={"frame_id": "tool0"}) as (n, arm):
        arm.client.wait_for_server(timeout_sec=10)
        result = arm.send(GuardedMove.Goal())
        done = result is not None and arm.spin(10, result.done)
        reason = result.result().result.reason if done else ""
        moving = [z for _, z in arm.commands if not z]
        check("frames: an estimate in another frame ends the goal, both named, nothing moves",
              '"tool0"' in reason and '"biotac"' in reason and "biotac_frame" in reason and not moving,
              f"{reason!r}; {len(moving)} moving commands")


def main():
    os.environ.setdefault("TACTILE_FORCE_CACHE", os.path.join(REPO, "target", "ros-test-cache"))
    ways_out()
    during_guided()
    arm_side_timeout()
    stop_service()
    controller_lifecycle()
    driver_lifecycle()
    best_effort_estimate()
    silent_input()
    wrong_estimate_frame()
    calibration_ft(None)
    calibration_ft("ft_sensor_link")
    return summary()


if __name__ == "__main__":
    sys.exit(main())
