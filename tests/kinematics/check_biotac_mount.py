"""The BioTac mount model (config/biotac_mount.urdf.xacro) against the tool
parameters the controller uses.

For each shipped robot (config/<robot>.yaml, whose tool mounts differ in
their roll-pitch-yaw): the macro is called as its header says, with the
file's `robot.tip_link` as parent and `robot.tool_xyz_m` and
`robot.tool_rpy_deg` copied as they are, expanded by ROS's xacro, put into
config/<robot>.urdf, and loaded by Pinocchio. The placement of the
`biotac` frame in the tip link, at the neutral and at random
configurations, must be the transform of the parameters (translation, then
rotation Rz(yaw) Ry(pitch) Rx(roll) of the degrees, computed here) to 1e-9
m and 1e-9 rad. As a control, the macro called with another robot's angles
must miss it by more than 1 rad.

Usage: check_biotac_mount.py. Prints one line per check and exits 1 if any
fails.
"""

import os
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import xacro
import yaml

TOL = 1e-9
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MOUNT = os.path.join(REPO, "config", "biotac_mount.urdf.xacro")
ROBOTS = ("pa10", "ur5", "panda")
FRAME = "biotac"


def tool_params(robot):
    """(tip link, xyz (m), rpy (deg)) of config/<robot>.yaml."""
    with open(os.path.join(REPO, "config", f"{robot}.yaml")) as f:
        p = yaml.safe_load(f)["/**"]["ros__parameters"]["robot"]
    return p["tip_link"], p["tool_xyz_m"], p["tool_rpy_deg"]


def expected(xyz, rpy_deg):
    """The tool mount as a placement: URDF's fixed-axis roll-pitch-yaw."""
    r, p, y = np.radians(rpy_deg)
    cx, sx, cy, sy, cz, sz = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return pin.SE3(rz @ ry @ rx, np.array(xyz, dtype=float))


def mounted(robot, tip, xyz, rpy_deg):
    """config/<robot>.urdf with the macro's joint and link, as a file."""
    words = lambda values: " ".join(str(v) for v in values)  # noqa: E731
    call = (f'<robot name="mount" xmlns:xacro="http://www.ros.org/wiki/xacro">'
            f'<xacro:include filename="{MOUNT}"/>'
            f'<xacro:biotac_mount parent="{tip}" xyz_m="{words(xyz)}" rpy_deg="{words(rpy_deg)}"/>'
            f"</robot>")
    with tempfile.NamedTemporaryFile("w", suffix=".urdf.xacro", delete=False) as f:
        f.write(call)
    try:
        snippet = ET.fromstring(xacro.process_file(f.name).toxml())
    finally:
        os.remove(f.name)
    arm = ET.parse(os.path.join(REPO, "config", f"{robot}.urdf"))
    for element in snippet:
        arm.getroot().append(element)
    out = tempfile.NamedTemporaryFile("wb", suffix=".urdf", delete=False)
    arm.write(out)
    out.close()
    return out.name


def placement_errors(path, tip, want):
    """The largest translation (m) and rotation (rad) error of the BioTac
    frame in the tip link, over the neutral and 20 random configurations."""
    model = pin.buildModelFromUrdf(path)
    data = model.createData()
    tip_id = model.getFrameId(tip, pin.FrameType.BODY)
    biotac = model.getFrameId(FRAME, pin.FrameType.BODY)
    lower = np.where(np.isfinite(model.lowerPositionLimit), model.lowerPositionLimit, -np.pi)
    upper = np.where(np.isfinite(model.upperPositionLimit), model.upperPositionLimit, np.pi)
    pin.seed(7)
    configs = [pin.neutral(model)] + [pin.randomConfiguration(model, lower, upper) for _ in range(20)]
    worst = [0.0, 0.0]
    for q in configs:
        pin.framesForwardKinematics(model, data, q)
        got = data.oMf[tip_id].actInv(data.oMf[biotac])
        err = want.actInv(got)
        worst[0] = max(worst[0], float(np.linalg.norm(err.translation)))
        worst[1] = max(worst[1], float(np.linalg.norm(pin.log3(err.rotation))))
    return worst


def main():
    results = []
    params = {robot: tool_params(robot) for robot in ROBOTS}
    for robot, (tip, xyz, rpy) in params.items():
        path = mounted(robot, tip, xyz, rpy)
        try:
            dt, dr = placement_errors(path, tip, expected(xyz, rpy))
        finally:
            os.remove(path)
        ok = dt <= TOL and dr <= TOL
        results.append(ok)
        print(f"{'ok  ' if ok else 'FAIL'} {robot}: {tip} -> {FRAME} from the mount model, tool_xyz_m {xyz}, "
              f"tool_rpy_deg {rpy}: errors {dt:.1e} m, {dr:.1e} rad (at most {TOL:g})", flush=True)
    # The control: the PA10's mount given the UR5's angles.
    tip, xyz, rpy = params["pa10"]
    path = mounted("pa10", tip, xyz, params["ur5"][2])
    try:
        _, dr = placement_errors(path, tip, expected(xyz, rpy))
    finally:
        os.remove(path)
    ok = dr > 1.0
    results.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} control: the PA10 with the UR5's tool_rpy_deg misses the PA10's "
          f"mount by {dr:.3f} rad (more than 1)", flush=True)
    print(f"{sum(results)} passed, {len(results) - sum(results)} failed")
    sys.exit(0 if all(results) else 1)


if __name__ == "__main__":
    main()
