"""One coupling for every kind of actuation: the motor-from-joint matrix G and the maps a controller needs.

A device moves its joints through cable routing (``[[transmissions]]``), capstan drives (``[[drives]]``) or geared
motors with a coupling matrix (``[[actuators]]``). All three end in the same linear map (docs/naming.md, ``G``):

* ``motor_from_joint_position`` G: q_motor = G q (active joints) [rad/rad]
* ``joint_from_motor_position`` G⁻¹: q = G⁻¹ q_motor
* ``joint_from_motor_torque`` Gᵀ: τ_J = Gᵀ C_m (virtual work: C_mᵀ q̇_m = τ_Jᵀ q̇)
* ``motor_from_joint_torque`` G⁻ᵀ: C_m = G⁻ᵀ τ_J (lossless feedforward)

:func:`coupling` is the one function that gives them, for any device; G comes from
``SerialDevice.motor_joint_matrix()`` (R_m⁻¹K for a routing, diag(N) for drives, diag(N)(I + coupling) for
actuators), in the file's motor order. A rectangular G (more tendons than joints) gets the Moore–Penrose
pseudo-inverse, and the result says so (``inverse = "pseudo"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MATRIX_NAMES = ("motor_from_joint_position", "joint_from_motor_position", "joint_from_motor_torque",
                "motor_from_joint_torque")
"""The four maps, in the order they are printed (names as :data:`tendyn.transmission.MATRIX_NAMES`)."""

MATRIX_SYMBOLS = {"motor_from_joint_position": "G", "joint_from_motor_position": "G⁻¹",
                  "joint_from_motor_torque": "Gᵀ", "motor_from_joint_torque": "G⁻ᵀ"}

MATRIX_UNITS = {"motor_from_joint_position": "rad/rad", "joint_from_motor_position": "rad/rad",
                "joint_from_motor_torque": "N·m/N·m", "motor_from_joint_torque": "N·m/N·m"}
"""Units of the maps (a prismatic joint reads m for rad and N for N·m on its side)."""

ACTUATION_KINDS = ("transmissions", "drives", "actuators")


@dataclass(frozen=True)
class Coupling:
    """The motor–joint coupling of a device.

    Attributes
    ----------
    device : device name
    actuation : "transmissions", "drives" or "actuators" (the device-file section)
    motors : motor names in the file's order (row i of G is motor i)
    joints : active joint names (column j of G)
    joint_numbers : 1-based file numbers of the active joints
    G : (n_motors, n_joints) motor_from_joint_position [rad/rad]
    inverse : "exact" (square, invertible) or "pseudo" (rectangular: Moore–Penrose)
    K, motor_radius : the routing (``[[transmissions]]`` only, else None): K (m, n) [m], R_m (m,) [m]
    """

    device: str
    actuation: str
    motors: tuple[str, ...]
    joints: tuple[str, ...]
    joint_numbers: tuple[int, ...]
    G: np.ndarray
    inverse: str
    K: np.ndarray | None = None
    motor_radius: np.ndarray | None = None

    @property
    def n_motors(self) -> int:
        return self.G.shape[0]

    @property
    def n_joints(self) -> int:
        return self.G.shape[1]

    def matrices(self) -> dict[str, np.ndarray]:
        """The four maps (copies), keyed by :data:`MATRIX_NAMES`."""
        G = np.array(self.G, float)
        Ginv = np.linalg.inv(G) if self.inverse == "exact" else np.linalg.pinv(G)
        return {"motor_from_joint_position": G, "joint_from_motor_position": Ginv,
                "joint_from_motor_torque": G.T.copy(), "motor_from_joint_torque": Ginv.T.copy()}

    def motor_joints(self) -> list[list[int]]:
        """Per motor, the 1-based joint numbers its angle depends on (nonzero entries of its row of G)."""
        return [[self.joint_numbers[j] for j in np.flatnonzero(np.abs(row) > 1e-12)] for row in self.G]

    def to_dict(self) -> dict:
        out = {"device": self.device, "actuation": self.actuation, "motors": list(self.motors),
               "joints": list(self.joints), "joint_numbers": list(self.joint_numbers), "inverse": self.inverse,
               **{k: v.tolist() for k, v in self.matrices().items()}, "units": dict(MATRIX_UNITS)}
        if self.K is not None:
            out["K"] = self.K.tolist()
            out["R_m"] = np.diag(self.motor_radius).tolist()
            out["units"].update({"K": "m", "R_m": "m"})
        return out

    def table(self) -> str:
        lines = [f"{self.device}: {self.n_motors} motors, {self.n_joints} active joints ([[{self.actuation}]]); "
                 "motor i = row i, in the file's order"]
        for name, joints in zip(self.motors, self.motor_joints()):
            lines.append(f"  {name}: joints {', '.join(map(str, joints))}")
        for key, M in self.matrices().items():
            lines.append(matrix_text(f"{key} ({MATRIX_SYMBOLS[key]})", M, MATRIX_UNITS[key]))
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table()


def matrix_text(name: str, M: np.ndarray, unit: str) -> str:
    """A matrix as `routing show` prints it: a title line and one indented line per row."""
    rows = "\n".join("    " + "  ".join(f"{v:+10.5f}" for v in row) for row in np.atleast_2d(M))
    return f"  {name} [{unit}]\n{rows}"


def coupling(device) -> Coupling:
    """The coupling of any serial device (``[[transmissions]]``, ``[[drives]]`` or ``[[actuators]]``).

    Raises ValueError for a device without a coupling (a tendon bench: one 2N channel).
    """
    if getattr(device, "kind", None) != "serial":
        raise ValueError(f"{device.name} is a tendon bench (one 2N channel): it has no motor–joint coupling")
    kin = device.kinematics
    active = [num for num, js in enumerate(kin.joints, start=1) if js.actuated and js.sigma != 2]
    G = np.asarray(device.motor_joint_matrix(), float)
    K = r_m = None
    if device.actuators:
        actuation, motors = "actuators", tuple(a.name for a in device.actuators)
    elif device.drives:
        actuation, motors = "drives", tuple(d.name for d in device.drives)
    else:
        actuation, motors = "transmissions", tuple(t.name for t in device.transmissions)
        arr = device.routing_arrays()
        K, r_m = np.array(arr["K"], float), np.array(arr["motor_radius"], float)
    square = G.shape[0] == G.shape[1]
    return Coupling(device=device.name, actuation=actuation, motors=motors,
                    joints=tuple(kin.joints[num - 1].name for num in active), joint_numbers=tuple(active),
                    G=G, inverse="exact" if square else "pseudo", K=K, motor_radius=r_m)
