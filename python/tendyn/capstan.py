"""Capstan drives (S2 §V): one motor per active joint through a cable capstan of ratio N.

Kinematics q_m = N q and statics C_m = τ_J / N (lossless), the maps a controller needs, in the same
shape as :meth:`tendyn.transmission.Transmission.matrices`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CapstanDrives", "reflected_stiffness", "total_stiffness"]


def total_stiffness(stiffness_motor, servo_stiffness_motor=None):
    """K_tot = 1 / (1/K_T + 1/K_E) [N·m/rad], motor side (S2 eq. 19): the capstan cable K_T in series with the
    position servo K_E; K_E None (or inf) gives K_T, K_E = 0 gives 0. Scalars or arrays (per drive). The one
    definition the device (``Drive.total_stiffness_motor``), the operational maps and the S2 pipeline read."""
    kt = np.asarray(stiffness_motor, float)
    ke = np.inf if servo_stiffness_motor is None else np.asarray(servo_stiffness_motor, float)
    with np.errstate(divide="ignore"):
        k = 1.0 / (1.0 / kt + 1.0 / ke)
    return float(k) if np.ndim(k) == 0 else k


def reflected_stiffness(stiffness_motor, ratio):
    """A motor-side stiffness seen at the joint [N·m/rad] = N² K (ERRATA eq. 19: the motor turns N q). Scalars
    or arrays (per drive)."""
    k = np.asarray(ratio, float) ** 2 * np.asarray(stiffness_motor, float)
    return float(k) if np.ndim(k) == 0 else k


class CapstanDrives:
    """The capstan drives of a device (``[[drives]]`` in its file), ordered by driven joint."""

    def __init__(self, drives):
        self.drives = tuple(drives)
        self.ratio = np.array([d.ratio for d in self.drives], float)

    @classmethod
    def from_device(cls, device) -> "CapstanDrives":
        return cls(device.drives)

    @property
    def n(self) -> int:
        return self.ratio.size

    def matrices(self) -> dict[str, np.ndarray]:
        """q_m = N q, q = N⁻¹ q_m, C_m = N⁻¹ τ_J, τ_J = N C_m; ``K`` = diag(N) [-] (q_m = K q)."""
        N = self.ratio
        return {"joint_from_motor_position": np.diag(1 / N), "motor_from_joint_position": np.diag(N),
                "motor_from_joint_torque": np.diag(1 / N), "joint_from_motor_torque": np.diag(N),
                "K": np.diag(N)}

    def drive_table(self) -> list[dict]:
        """One row per drive: joint, ratio, capstan stiffness and friction at the motor (SI)."""
        return [{"drive": d.name, "joint": d.joint, "ratio": d.ratio, "stiffness_motor_Nm_rad": d.stiffness_motor,
                 "coulomb_motor_Nm": d.coulomb_motor, "viscous_motor_Nms_rad": d.viscous_motor}
                for d in self.drives]
