"""A UR5 this project did not write, in a physics engine it did not write,
driven over DDS as a real arm is: MuJoCo (PyPI `mujoco`) simulates
example-robot-data's UR5 (its URDF, meshes stripped, the links' inertias as
published), and a ROS 2 node publishes its joint states at the arm's
command cycle and takes velocity commands the way a CB-series UR does: a
command arriving during one cycle acts from the cycle after the next read
(one to two cycles late), then through a first-order servo lag, and each
joint's servo integrates it into a position it holds.

On its tool flange sits a fingertip like the BioTac mounted as in
config/ur5.yaml: a pad on springs (1250 N/m along its normal, 1500 N/m
across it, the BioTac skin's stiffness at 1 N in config/world.yaml, but
linear), whose spring force is the force the controller is given, as
`biotac/wrench_estimate` at 100 Hz with 5 mN of noise:
this plant replaces the BioTac and its estimator, not the controller. The
pad touches, through MuJoCo's contacts (friction 1):

- `object`: a plate of 50 g 10 mm under the pad on a spring of the
  stiffness asked (N/m), along the pad's normal, damped at half the
  critical damping (a soft body does not ring), or fixed (`rigid`);
- `finger`: a fingertip (flat, 30 mm square) under the pad that follows the guided scene's path
  (config/guided_move.yaml: waits, minimum-jerk pushes and circles, in the
  BioTac frame at the start) on position servos ([`Finger`]: by default
  300 N/m along the pad's normal and across it, a person's finger and hand
  as config/world.yaml's fingertip, 3 N s/m, 20 g, friction 1).

The truth for the figures is the pad's spring force at each physics step;
the plant records it, stamped, every 10 ms. The estimate it publishes is
that force with noise (`Estimates`): by default the force at the frame's
end with 5 mN; or, as a BioTac's estimator gives it, the force averaged
over the 10 ms frame with 7 mN, sent after a random delay of up to
`jitter_s` (an ordinary process's timing) and stamped when sent.
"""

import contextlib
import gc
import math
import os
import re
import sys
import threading
import time

import mujoco
import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from tactile_force_msgs.msg import WrenchEstimate
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
          "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
# config/ur5.yaml: the start pose (deg) and the BioTac's mount on tool0.
START_DEG = [0.0, -90.0, 90.0, 0.0, 3.0, -90.0]
TOOL_XYZ = [0.0, 0.0, 0.09]
TOOL_RPY_DEG = [0.0, -90.0, 0.0]
# The pad: where the BioTac touches along its axis (config/world.yaml,
# contact_x_mm) and the skin's springs.
CONTACT_X = -0.004
PAD_RADIUS = 0.007
SKIN_NORMAL = 1250.0
SKIN_SHEAR = 1500.0
SKIN_DAMPING = 2.0
# The joints' servos: each integrates its velocity command into a position
# target and tracks it as a critically damped spring on the joint's inertia
# at the start pose, of this natural frequency (rad/s, ~30 Hz).
SERVO_OMEGA = 200.0
# Contacts: stiff against the skin's springs (a 2 ms time constant, twice
# the physics step, critically damped), and no creep under static friction
# (MuJoCo's noslip iterations).
CONTACT_SOLREF = [0.002, 1.0]
NOSLIP_ITERATIONS = 10
PHYSICS_DT = 0.0005
# The object's plate (kg) and its damping ratio on its spring.
PLATE_MASS = 0.05
PLATE_DAMPING_RATIO = 0.5
# The servos, the finger and the command cycles move in ticks of 1 ms.
TICK = 0.001
ESTIMATE_PERIOD = 0.01
NOISE_N = 0.005


class Finger:
    """A person's fingertip: its servos' stiffness along the pad's normal and
    across it (N/m), damping (N s/m), mass (kg) and friction."""

    def __init__(self, normal=300.0, shear=300.0, damping=3.0, mass=0.02, friction=1.0):
        self.normal, self.shear, self.damping, self.mass, self.friction = normal, shear, damping, mass, friction

    def __str__(self):
        return (f"{self.normal:g}/{self.shear:g} N/m, {self.damping:g} N s/m, {1e3 * self.mass:g} g, "
                f"friction {self.friction:g}")


class Estimates:
    """How the plant's force becomes the published estimate: `averaged` over
    the 10 ms frame (else the force at its end), Gaussian noise `noise_n`,
    sent after a uniform delay of up to `jitter_s`."""

    def __init__(self, averaged=False, noise_n=NOISE_N, jitter_s=0.0):
        self.averaged, self.noise_n, self.jitter_s = averaged, noise_n, jitter_s


def erd_urdf():
    """example-robot-data's UR5 URDF, from the installed package."""
    base = os.path.join(sys.prefix, "lib", "python%d.%d" % sys.version_info[:2], "site-packages",
                        "cmeel.prefix", "share", "example-robot-data", "robots")
    with open(os.path.join(base, "ur_description", "urdf", "ur5_robot.urdf")) as f:
        return f.read()


def rpy_matrix(rpy):
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def quat(m):
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, m.flatten())
    return q


def min_jerk(u):
    u = min(max(u, 0.0), 1.0)
    return u ** 3 * (10 - 15 * u + 6 * u * u)


class FingerPath:
    """The guided scene's finger path (sim/finger.rs's segments), offsets in
    the BioTac frame at the start (m)."""

    def __init__(self, lines):
        self.lines = list(lines)
        self.segments = []
        t, at = 0.0, np.zeros(3)
        for line in lines:
            w = line.split()
            if w[0] == "wait":
                d, seg = float(w[1]), ("wait", None)
                end = at
            elif w[0] == "push":
                disp = np.array([float(x) for x in w[1:4]]) * 1e-3
                d = 1.875 * np.linalg.norm(disp) / float(w[4])
                seg, end = ("push", disp), at + disp
            else:
                r = float(w[1]) * 1e-3
                d = 1.875 * 2 * math.pi * r / float(w[2])
                seg, end = ("circle", r), at
            self.segments.append((t, d, at.copy(), seg))
            t, at = t + d, end
        self.duration = t
        self.end = at

    def segment_at(self, t):
        """The index of the path's line under way at `t` (s), None after
        its end."""
        return next((i for i, (start, d, _, _) in enumerate(self.segments) if start <= t < start + d), None)

    def at(self, t):
        for start, d, frm, (kind, arg) in self.segments:
            if start <= t < start + d:
                s = min_jerk((t - start) / d)
                if kind == "push":
                    return frm + arg * s
                if kind == "circle":
                    th = 2 * math.pi * s
                    return frm + np.array([arg * (math.cos(th) - 1), arg * math.sin(th), 0.0])
                return frm
        return np.zeros(3) if t <= 0 else self.end


@contextlib.contextmanager
def without_gc_pauses():
    """Python's cyclic collector off while the plant runs: a full collection
    of the records paused the physics 29-44 ms (a real arm's cycle does not
    wait), which made the plant run late and the estimates go stale."""
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.unfreeze()


class Ur5Plant(Node):
    """The UR5 in MuJoCo as a ROS 2 node; `body`: ("object", stiffness N/m
    or None for rigid) or ("finger", path lines[, Finger]); `cycle_s`,
    `lag_s`: the arm's command cycle and servo lag; `estimates`: how the
    force is published (Estimates)."""

    def __init__(self, body, cycle_s, lag_s, seed=1, estimates=None):
        super().__init__("ur5_mujoco")
        self.cycle_s, self.lag_s = cycle_s, lag_s
        self.estimates = estimates or Estimates()
        self.frame = []  # the pad's force at each tick of the current frame
        self.pending = []  # (due tick, force) estimates not sent yet
        self.sent_at = None  # wall-clock time of the last estimate sent
        self.longest_gap_s = 0.0  # the longest wall-clock time between two
        self.rng = np.random.default_rng(seed)
        self.model, self.data = self._build(body)
        self.lock = threading.Lock()
        self.latest = np.zeros(6)  # the latest command received
        self.read = np.zeros(6)  # read at the last cycle, acting from the next
        self.acting = np.zeros(6)
        self.servo = np.zeros(6)  # the command through the servo lag
        self.truth = []  # (stamp, force in the BioTac frame) every 10 ms
        self.truth_segments = []  # with a finger, its path's segment under way at each
        # (stamp, BioTac velocity, finger velocity), start BioTac frame (m/s)
        self.motion = []
        self.commands = 0
        self.nonzero = 0  # commands with a velocity that is not zero
        self.behind_s = 0.0  # the most the physics fell behind real time
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_publisher(String, "/robot_description", latched).publish(String(data=self.urdf))
        self.joints = self.create_publisher(JointState, "joint_states", 10)
        self.estimate = self.create_publisher(WrenchEstimate, "biotac/wrench_estimate", 10)
        self.create_subscription(Float64MultiArray, "velocity_controller/commands", self._on_command, 10)
        self.running = True

    def _on_command(self, m):
        if len(m.data) == 6 and all(math.isfinite(v) for v in m.data):
            with self.lock:
                self.latest = np.array(m.data)
                self.commands += 1
                self.nonzero += any(v != 0.0 for v in m.data)

    def _build(self, body):
        urdf = erd_urdf()
        self.urdf = urdf
        stripped = re.sub(r"<(visual|collision)>.*?</\1>", "", urdf, flags=re.S)
        stripped = stripped.replace(
            "</robot>", '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco></robot>')
        spec = mujoco.MjSpec.from_string(stripped)
        spec.option.timestep = PHYSICS_DT
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.noslip_iterations = NOSLIP_ITERATIONS
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        # The arm's own controller holds it against gravity (a real UR
        # does); the pad, the plate and the finger hang on springs.
        spec.option.gravity = [0.0, 0.0, 0.0]
        for name in JOINTS:
            a = spec.add_actuator()
            a.name, a.target = name, name
            a.trntype = mujoco.mjtTrn.mjTRN_JOINT
            a.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
            a.actearly = 1
            a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        # The BioTac on tool0, its pad on three springs.
        tool = spec.body("tool0")
        biotac = tool.add_body(name="biotac", pos=TOOL_XYZ,
                               quat=quat(rpy_matrix([math.radians(a) for a in TOOL_RPY_DEG])))
        biotac.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.001, 0, 0], mass=0.001,
                        contype=0, conaffinity=0)
        pad = biotac.add_body(name="pad", pos=[CONTACT_X, 0, 0])
        for axis, k in (([1, 0, 0], SKIN_SHEAR), ([0, 1, 0], SKIN_SHEAR), ([0, 0, 1], SKIN_NORMAL)):
            pad.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, stiffness=k, damping=SKIN_DAMPING)
        pad.add_geom(name="pad", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[PAD_RADIUS, 0, 0],
                     mass=0.005, friction=[1.0, 0.005, 0.0001], condim=3, solref=CONTACT_SOLREF)
        model = spec.compile()
        data = mujoco.MjData(model)
        for name, deg in zip(JOINTS, START_DEG):
            data.joint(name).qpos = math.radians(deg)
        mujoco.mj_forward(model, data)
        # Where the pad's lowest point is, and its normal (the BioTac's -z).
        rot = data.body("biotac").xmat.reshape(3, 3)
        self.start_rot = rot.copy()
        normal = rot @ np.array([0, 0, -1.0])
        bottom = data.body("pad").xpos + normal * PAD_RADIUS
        kind, arg = body[:2]
        world = spec.worldbody
        if kind == "object":
            plate_half = 0.005
            centre = bottom + normal * (0.010 + plate_half)
            q = quat(rot)
            if arg is None:
                world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, plate_half], pos=centre,
                               quat=q, friction=[1.0, 0.005, 0.0001], solref=CONTACT_SOLREF)
            else:
                obj = world.add_body(name="object", pos=centre, quat=q)
                obj.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1], stiffness=arg,
                              damping=PLATE_DAMPING_RATIO * 2.0 * math.sqrt(arg * PLATE_MASS))
                obj.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, plate_half], mass=PLATE_MASS,
                             friction=[1.0, 0.005, 0.0001], solref=CONTACT_SOLREF)
            self.path = None
        else:
            self.path = FingerPath(arg)
            spec_f = body[2] if len(body) > 2 else Finger()
            half = 0.004  # the finger's pad: flat where it meets the BioTac's
            centre = bottom + normal * (0.002 + half)
            finger = world.add_body(name="finger", pos=centre, quat=quat(rot))
            # Its x and y lie across the pad, z along its normal.
            for i, (axis, k) in enumerate((([1, 0, 0], spec_f.shear), ([0, 1, 0], spec_f.shear),
                                           ([0, 0, 1], spec_f.normal))):
                finger.add_joint(name=f"finger_{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis,
                                 damping=spec_f.damping)
                a = spec.add_actuator()
                a.name, a.target = f"finger_{i}", f"finger_{i}"
                a.trntype = mujoco.mjtTrn.mjTRN_JOINT
                a.gainprm[0] = k
                a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
                a.biasprm[1] = -k
            finger.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.015, 0.015, half], mass=spec_f.mass,
                            friction=[spec_f.friction, 0.005, 0.0001], condim=3, solref=CONTACT_SOLREF)
        model = spec.compile()
        data = mujoco.MjData(model)
        for name, deg in zip(JOINTS, START_DEG):
            data.joint(name).qpos = math.radians(deg)
        mujoco.mj_forward(model, data)
        self.arm_dofs = [model.joint(n).dofadr[0] for n in JOINTS]
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        for name, dof in zip(JOINTS, self.arm_dofs):
            inertia = full[dof, dof]
            a = model.actuator(name)
            a.gainprm[0] = inertia * SERVO_OMEGA ** 2
            a.biasprm[1] = -inertia * SERVO_OMEGA ** 2
            a.biasprm[2] = -2.0 * inertia * SERVO_OMEGA
            data.act[a.actadr[0]] = data.joint(name).qpos[0]
        self.pad_dofs = [model.jnt_dofadr[j] for j in range(model.njnt)
                         if model.jnt_bodyid[j] == model.body("pad").id]
        return model, data

    def pad_force(self):
        """The force on the pad, BioTac frame (N): its springs' force."""
        q = np.array([self.data.qpos[self.model.jnt_qposadr[j]] for j in range(self.model.njnt)
                      if self.model.jnt_bodyid[j] == self.model.body("pad").id])
        # The force the body puts on the pad balances its springs: a pad
        # pushed towards +z of the BioTac frame is pressed, +F.
        return np.array([SKIN_SHEAR * q[0], SKIN_SHEAR * q[1], SKIN_NORMAL * q[2]])

    def record_motion(self, t):
        """The BioTac's and the finger's velocity over the last 10 ms."""
        here = (self.data.body("biotac").xpos.copy(),
                self.data.body("finger").xpos.copy() if self.path is not None else np.zeros(3))
        if hasattr(self, "_last"):
            v = [self.start_rot.T @ (p - q) / ESTIMATE_PERIOD for p, q in zip(here, self._last)]
            self.motion.append((t, v[0], v[1]))
        self._last = here

    def guided_record(self, until=math.inf):
        """(stamp, force) and the BioTac's and the finger's velocities by
        stamp up to the stamp `until`, for the guided move's figures."""
        arm = {t: tuple(a) for t, a, _ in self.motion if t <= until}
        finger = {t: tuple(f) for t, _, f in self.motion if t <= until}
        forces = [(t, tuple(f)) for t, f in self.truth if t <= until]
        return forces, arm, finger

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def stamp(self, msg, t):
        msg.header.stamp.sec = int(t)
        msg.header.stamp.nanosec = int((t - int(t)) * 1e9)
        msg.header.frame_id = "biotac"

    def run(self, seconds):
        """Runs the plant in real time for `seconds`, publishing as it goes:
        the servos and the finger move every TICK, the physics in between."""
        with without_gc_pauses():
            self._run(seconds)

    def _run(self, seconds):
        start = time.monotonic()
        steps = round(TICK / PHYSICS_DT)
        ticks_per_cycle = max(1, round(self.cycle_s / TICK))
        ticks_per_estimate = round(ESTIMATE_PERIOD / TICK)
        alpha = 1.0 if self.lag_s <= 0 else 1 - math.exp(-TICK / self.lag_s)
        arm = [self.model.actuator(n).id for n in JOINTS]
        finger = [self.model.actuator(f"finger_{i}").id for i in range(3)] if self.path else []
        qpos = [self.model.joint(n).qposadr[0] for n in JOINTS]
        tick = 0
        while self.running and tick * TICK < seconds:
            t_sim = tick * TICK
            ahead = t_sim - (time.monotonic() - start)
            if ahead > 0:
                time.sleep(ahead)
            self.behind_s = max(self.behind_s, -ahead)
            if tick % ticks_per_cycle == 0:
                with self.lock:
                    # The command read at the last cycle acts from now.
                    self.acting, self.read = self.read, self.latest.copy()
                js = JointState(name=JOINTS, position=[float(self.data.qpos[i]) for i in qpos])
                js.header.stamp = self.get_clock().now().to_msg()
                self.joints.publish(js)
            if finger:
                self.data.ctrl[finger] = self.path.at(t_sim)
            self.servo += (self.acting - self.servo) * alpha
            self.data.ctrl[arm] = self.servo
            mujoco.mj_step(self.model, self.data, steps)
            self.frame.append(self.pad_force())
            if tick % ticks_per_estimate == 0:
                self.end_frame(tick)
            while self.pending and self.pending[0][0] <= tick:
                self.publish_estimate(self.pending.pop(0)[1])
            tick += 1

    def end_frame(self, tick):
        """Records the pad's force (the truth) and queues its estimate: due
        now, or after the jitter's random delay."""
        f = self.pad_force()
        t = self.now()
        self.truth.append((t, f))
        if self.path is not None:
            self.truth_segments.append(self.path.segment_at(tick * TICK))
        self.record_motion(t)
        e = self.estimates
        seen = np.mean(self.frame, axis=0) if e.averaged else f
        self.frame = []
        delay = round(self.rng.uniform(0.0, e.jitter_s) / TICK) if e.jitter_s > 0 else 0
        self.pending.append((tick + delay, seen + self.rng.normal(0, e.noise_n, 3)))

    def publish_estimate(self, force):
        """An estimate of the pad's force, stamped now, as the estimator's."""
        t = self.now()
        sent = time.monotonic()
        if self.sent_at is not None:
            self.longest_gap_s = max(self.longest_gap_s, sent - self.sent_at)
        self.sent_at = sent
        m = WrenchEstimate(estimated=[True, True, True, False, False, False])
        self.stamp(m, t)
        m.wrench.force.x, m.wrench.force.y, m.wrench.force.z = (float(v) for v in force)
        m.stddev.force.x = m.stddev.force.y = m.stddev.force.z = self.estimates.noise_n
        for w in (m.wrench, m.stddev):
            w.torque.x = w.torque.y = w.torque.z = math.nan
        self.estimate.publish(m)
