"""Capstan drives (S2 §V): one motor per active joint through a cable capstan of ratio N.

Kinematics q_m = N q and statics C_m = τ_J / N (lossless), the maps a controller needs, in the same
shape as :meth:`tendyn.transmission.Transmission.matrices`.
"""

from __future__ import annotations

import numpy as np


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
