"""Our forward kinematics and Jacobian against Pinocchio's, on real robot
descriptions.

For each robot, 100 random configurations within the joint limits (a
continuous joint in [-pi, pi]): `tactile_force robot --urdf F --base B
--tip T --q ... --json` against Pinocchio (`pin`, an independent library)
on the same URDF: the tip's position and orientation in the base frame,
and the Jacobian of the tip origin in the base frame (Pinocchio's
LOCAL_WORLD_ALIGNED, rotated into the base frame). The descriptions are
example-robot-data's (UR5, Franka Panda with its fingers off the chain,
Kinova Jaco j2s6s200 with three continuous joints, the five-joint SO-100)
and ours (config/pa10.urdf, ur5.urdf, panda.urdf); ours of the UR5 and the
Panda are also compared with example-robot-data's, through Pinocchio.

Usage: check_pinocchio.py BINARY ROBOTS_DIR. Prints one line per check and
exits 1 if any error exceeds 1e-9 (m, rad).
"""

import json
import os
import subprocess
import sys

import numpy as np
import pinocchio as pin

TOL = 1e-9
CONFIGS = 100
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def load(path):
    model = pin.buildModelFromUrdf(path)
    return model, model.createData()


def chain_joints(model, names):
    """Pinocchio's joint of each of our chain's joints, by name."""
    return [model.joints[model.getJointId(n)] for n in names]


def pin_q(model, joints, values):
    """A Pinocchio configuration with our chain's values (continuous joints
    are (cos, sin) in Pinocchio), the others at their neutral value."""
    q = pin.neutral(model)
    for j, v in zip(joints, values):
        if j.nq == 2:
            q[j.idx_q], q[j.idx_q + 1] = np.cos(v), np.sin(v)
        else:
            q[j.idx_q] = v
    return q


def link(model, name):
    """The frame of a URDF link (a joint may bear the same name)."""
    return model.getFrameId(name, pin.FrameType.BODY)


def relative(model, data, q, base, tip):
    """The tip's pose in the base frame, and the base's rotation in the world."""
    pin.framesForwardKinematics(model, data, q)
    b = data.oMf[link(model, base)]
    return b.inverse() * data.oMf[link(model, tip)], b.rotation


def ours(binary, urdf, base, tip, values=None):
    cmd = [binary, "robot", "--urdf", urdf, "--base", base, "--tip", tip, "--json"]
    if values is not None:
        cmd += ["--q=" + ",".join(repr(float(v)) for v in values)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def quat_matrix(xyzw):
    x, y, z, w = xyzw
    return pin.Quaternion(w, x, y, z).toRotationMatrix()


def random_values(model, joints, rng):
    values = []
    for j in joints:
        if j.nq == 2:
            values.append(rng.uniform(-np.pi, np.pi))
        else:
            lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
            values.append(rng.uniform(lo, hi))
    return values


def check_robot(binary, name, urdf, base, tip, rng):
    model, data = load(urdf)
    names = ours(binary, urdf, base, tip)["joints"]
    joints = chain_joints(model, names)
    worst = {"position_m": 0.0, "rotation_rad": 0.0, "jacobian": 0.0}
    for _ in range(CONFIGS):
        values = random_values(model, joints, rng)
        mine = ours(binary, urdf, base, tip, values)
        q = pin_q(model, joints, values)
        pose, r_base = relative(model, data, q, base, tip)
        j_world = pin.computeFrameJacobian(model, data, q, link(model, tip),
                                           pin.LOCAL_WORLD_ALIGNED)
        cols = [j_world[:, j.idx_v] for j in joints]
        j_base = np.vstack([r_base.T @ np.array(cols).T[:3], r_base.T @ np.array(cols).T[3:]])
        err_p = np.abs(np.array(mine["position_m"]) - pose.translation).max()
        err_r = np.linalg.norm(pin.log3(quat_matrix(mine["quaternion_xyzw"]).T @ pose.rotation))
        err_j = np.abs(np.array(mine["jacobian"]) - j_base).max()
        worst["position_m"] = max(worst["position_m"], err_p)
        worst["rotation_rad"] = max(worst["rotation_rad"], err_r)
        worst["jacobian"] = max(worst["jacobian"], err_j)
    ok = all(v <= TOL for v in worst.values())
    print(f"{'ok  ' if ok else 'FAIL'} {name} ({base} -> {tip}, {len(names)} joints, {CONFIGS} "
          f"configurations): largest error position {worst['position_m']:.1e} m, rotation "
          f"{worst['rotation_rad']:.1e} rad, Jacobian {worst['jacobian']:.1e}", flush=True)
    return ok, worst


def check_same_chain(name, ours_urdf, theirs_urdf, base, tip, theirs_base, rng):
    """Our description against theirs, both through Pinocchio."""
    a, da = load(ours_urdf)
    b, db = load(theirs_urdf)
    names = [a.names[i] for i in range(1, a.njoints)]
    ja, jb = chain_joints(a, names), chain_joints(b, names)
    worst = 0.0
    for _ in range(CONFIGS):
        values = random_values(a, ja, rng)
        pa, _ = relative(a, da, pin_q(a, ja, values), base, tip)
        pb, _ = relative(b, db, pin_q(b, jb, values), theirs_base, tip)
        worst = max(worst, np.abs(pa.translation - pb.translation).max(),
                    np.linalg.norm(pin.log3(pa.rotation.T @ pb.rotation)))
    ok = worst <= TOL
    print(f"{'ok  ' if ok else 'FAIL'} {name}: config/ against example-robot-data, "
          f"{CONFIGS} configurations: largest error {worst:.1e} (m, rad)", flush=True)
    return ok, worst


def main():
    binary, robots = sys.argv[1], sys.argv[2]
    erd = lambda rel: os.path.join(robots, rel)  # noqa: E731
    cfg = lambda name: os.path.join(REPO, "config", name)  # noqa: E731
    rng = np.random.default_rng(1)
    cases = [
        ("UR5", erd("ur_description/urdf/ur5_robot.urdf"), "base_link", "tool0"),
        ("Franka Panda", erd("panda_description/urdf/panda.urdf"), "panda_link0", "panda_hand_tcp"),
        ("Kinova Jaco j2s6s200", erd("kinova_description/robots/kinova.urdf"), "base",
         "j2s6s200_end_effector"),
        ("SO-100", erd("so_arm_description/urdf/so100.urdf"), "base", "gripper"),
        ("PA10 (config/pa10.urdf)", cfg("pa10.urdf"), "base_link", "link7"),
        ("UR5 (config/ur5.urdf)", cfg("ur5.urdf"), "base_link", "tool0"),
        ("Panda (config/panda.urdf)", cfg("panda.urdf"), "panda_link0", "panda_link8"),
    ]
    results = [check_robot(binary, *case, rng)[0] for case in cases]
    results.append(check_same_chain("UR5", cfg("ur5.urdf"), erd("ur_description/urdf/ur5_robot.urdf"),
                                    "base_link", "tool0", "base_link", rng)[0])
    results.append(check_same_chain("Panda", cfg("panda.urdf"), erd("panda_description/urdf/panda.urdf"),
                                    "panda_link0", "panda_link8", "panda_link0", rng)[0])
    print(f"{sum(results)} passed, {len(results) - sum(results)} failed")
    sys.exit(0 if all(results) else 1)


if __name__ == "__main__":
    main()
