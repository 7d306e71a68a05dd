"""The dVRK MTM described to tendyn as a user would, from public facts only (generated at test/benchmark time).

Geometry: the MTM's public modified-DH table (the one WPI's main_mtm.ipynb writes, cell 9; lengths in m):
base to platform 0.2154, upper arm 0.2794, back-parallelogram link 0.1, forearm 0.3645, wrist offset 0.151.
Tree (file joint numbers): 1 outer yaw, 2 shoulder pitch, 3 elbow pitch (dVRK joints 1-3); 4, 5 the passive
back links of the shoulder parallelogram (closed loop: q4 = q2 + q3, q5 = -q3); 6 platform, 7 wrist pitch,
8 wrist yaw, 9 wrist roll (dVRK joints 4-7). Actuation: the dVRK coupling as [[actuators]] (q_motor = G q_dVRK,
rows [0, 1, 1] for motor 3 and [0, 0, 0.6697, 1] for motor 4: the MTM's JointToActuatorPosition). The wrist-pitch
gravity-compensation spring as a `spring` term: 0.1035 m along the platform to 0.0075 m on the wrist-pitch link at
23 deg, rest length 0.0613 m (WPI's model, cell 9), its stiffness identified. Inertial values are rough priors of a
user (not WPI's identified parameters): identification does not read them except to fix the null space.

No data of the MTM is written here: the logs are built from ../shared by :func:`mtm_log` in memory.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

COUPLING_4_3 = 0.6697                     # dVRK MTM: q_m4 = q4 + 0.6697 q3 (public dVRK configuration)
SPRING = {"h_s": 0.1035, "r_s": 0.0075, "q_o": math.radians(23.0), "l_r": 0.0613}


def _joint(j, name, ant, mu, alpha, d, r, theta, lo, hi, mass=0.5, com=(0.0, 0.0, 0.0), inertia=1e-3):
    i = [inertia, inertia, inertia, 0.0, 0.0, 0.0] if mass else [0.0] * 6
    return (f"[[kinematics.joints]]\nname = \"{name}\"\nj = {j}\nantecedent = {ant}\nmu = {mu}\nsigma = 0\n"
            f"alpha = {alpha!r}\nd = {d!r}\nr = {r!r}\ntheta_offset = {theta!r}\nlower = {lo!r}\nupper = {hi!r}\n"
            f"mass = {mass!r}\ncom = [{com[0]!r}, {com[1]!r}, {com[2]!r}]\ninertia = [{', '.join(map(repr, i))}]\n")


def mtm_device_text(cable_term: str = "", name: str = "dvrk_mtm") -> str:
    """The device file (TOML text); ``cable_term``: a [[terms]] block appended (e.g. from identify-term)."""
    p2 = math.pi / 2
    rad = math.radians
    joints = [
        _joint(1, "outer_yaw", 0, 1, 0.0, 0.0, -0.2154, 0.0, rad(-80), rad(60), 1.0),
        _joint(2, "shoulder_pitch", 1, 1, -p2, 0.0, 0.0, p2, rad(-30), rad(80)),
        _joint(3, "elbow_pitch", 2, 1, 0.0, 0.2794, 0.0, p2, rad(-50), rad(50)),
        _joint(4, "back_parallel_top", 1, 0, -p2, 0.0, 0.0, math.pi, rad(-40), rad(80)),
        _joint(5, "back_parallel_link", 4, 0, 0.0, 0.1, 0.0, -p2, rad(-50), rad(50)),
        _joint(6, "platform", 3, 1, -p2, 0.3645, 0.151, 0.0, rad(-100), rad(220)),
        _joint(7, "wrist_pitch", 6, 1, p2, 0.0, 0.0, 0.0, rad(-100), rad(200), 0.2),
        _joint(8, "wrist_yaw", 7, 1, -p2, 0.0, 0.0, p2, rad(-60), rad(60), 0.1),
        _joint(9, "wrist_roll", 8, 1, -p2, 0.0, 0.0, math.pi, rad(-500), rad(500), 0.05),
    ]
    hs, rs, qo = SPRING["h_s"], SPRING["r_s"], SPRING["q_o"]
    # spring ends: point b at r_s on the x axis of frame 7; point a on the platform, at angle pi + q_o from it in
    # the plane of joint 7 (frame 7 at q7 = 0 is frame 6 turned by Rx(pi/2): (x, y, 0) -> (x, 0, y))
    pa = (-hs * math.cos(qo), 0.0, -hs * math.sin(qo))
    acts = []
    for i, (j, coupling) in enumerate([(1, None), (2, None), (3, {"2": 1.0}), (6, {"3": COUPLING_4_3}), (7, None),
                                       (8, None), (9, None)]):
        c = "" if coupling is None else "coupling = { " + ", ".join(f'"{k}" = {v!r}' for k, v in coupling.items()) \
            + " }\n"
        acts.append(f"[[actuators]]\nname = \"m{i + 1}\"\njoint = {j}\nratio = 1.0\n{c}")
    return (f"schema = 1\n\n[device]\nname = \"{name}\"\ndescription = \"dVRK MTM (public DH, dVRK coupling)\"\n"
            "bandwidth_hz = 2.0\n\n[kinematics]\nconvention = \"mdh\"\ngravity = [0.0, 0.0, -9.81]\n\n"
            + "\n".join(joints)
            + "\n[[kinematics.constraints]]\njoint = 4\nterms = { \"2\" = 1.0, \"3\" = 1.0 }\n"
            "\n[[kinematics.constraints]]\njoint = 5\nterms = { \"3\" = -1.0 }\n\n"
            + "\n".join(acts)
            + f"\n[[terms]]\nname = \"wrist_spring\"\nkind = \"spring\"\nlink_a = 6\nlink_b = 7\n"
            f"point_a = [{pa[0]!r}, {pa[1]!r}, {pa[2]!r}]\npoint_b = [{rs!r}, 0.0, 0.0]\n"
            f"rest_length = {SPRING['l_r']!r}\n"
            + ("\n" + cable_term if cable_term else ""))


def write_mtm_device(folder: Path, cable_term: str = "", name: str = "dvrk_mtm") -> Path:
    path = Path(folder) / f"{name}.toml"
    path.write_text(mtm_device_text(cable_term, name), encoding="utf-8")
    return path


def mtm_log(csv: Path, device: str = "dvrk_mtm", rate_hz: float = 200.0):
    """A tendyn log of one of WPI's measured trajectories (5999 rows, 7 positions, 7 velocities, 7 torques in
    motor coordinates q_m = G q_dVRK, y = G^-T tau): q_motor_i, qd_motor_i, torque_motor_i."""
    from tendyn.io import make_log

    a = np.loadtxt(csv, delimiter=",")
    cols = {"time": np.arange(a.shape[0]) / rate_hz}
    cols.update({f"q_motor_{i + 1}": a[:, i] for i in range(7)})
    cols.update({f"qd_motor_{i + 1}": a[:, 7 + i] for i in range(7)})
    cols.update({f"torque_motor_{i + 1}": a[:, 14 + i] for i in range(7)})
    return make_log(cols, device=device, rate_hz=rate_hz, seed=None, experiment="exciting")


def sweep_log(csv: Path, device: str = "dvrk_mtm", rate_hz: float = 200.0):
    """WPI's joint-4 cable sweep (position [rad], velocity [rad/s], effort [N·m] of dVRK joint 4, the platform,
    file joint 6) as a tendyn log: q_joint_6, qd_joint_6 and torque_motor_4 (motor 4 alone reaches joint 6:
    tau_6 = y_4)."""
    from tendyn.io import make_log

    a = np.loadtxt(csv, delimiter=",")
    cols = {"time": np.arange(a.shape[0]) / rate_hz, "q_joint_6": a[:, 0], "qd_joint_6": a[:, 1],
            "torque_motor_4": a[:, 2]}
    return make_log(cols, device=device, rate_hz=rate_hz, seed=None, experiment="sweep")


WPI_ERRORS = (0.077, 0.149, 0.170, 0.223, 0.280, 0.234, 0.340)
"""WPI's published per-joint relative errors on trajectory `two` (main_mtm.ipynb, cell 105)."""


def wpi_filter(x, rate_hz: float = 200.0):
    """WPI's filter: 6th-order Butterworth, Wn = 1.8 Hz x 2 pi / rate (single-pass design frequency 5.65 Hz at
    200 Hz), forward-backward (scipy's filtfilt, odd padding 3 x order + 3 samples like theirs), along axis 0."""
    import scipy.signal

    b, a = scipy.signal.butter(6, 1.8 * 2 * np.pi / rate_hz)
    return scipy.signal.filtfilt(b, a, np.asarray(x, float), axis=0, padtype="odd", padlen=3 * 7 - 1)


def wpi_metric(csv: Path, predicted_motor, cable_motor_wpi, cut: int = 200, n: int = 2000) -> np.ndarray:
    """WPI's per-joint test error (cell 105): ‖y_f − ŷ‖ / ‖y_f − c‖ over the `n` samples after `cut`, y_f the
    measured motor-space torques filtered by :func:`wpi_filter`, ŷ the model's prediction (its cable term
    included), c WPI's cable torque (motor space) removed from the measured torques before filtering, as WPI
    does for the denominator. predicted_motor, cable_motor_wpi: (5999, 7) [N·m] at the log's samples."""
    a = np.loadtxt(csv, delimiter=",")
    y = a[:, 14:21]
    yf = wpi_filter(y)
    yf0 = wpi_filter(y - cable_motor_wpi)
    sl = slice(cut, cut + n)
    return np.linalg.norm(yf[sl] - predicted_motor[sl], axis=0) / np.linalg.norm(yf0[sl], axis=0)
