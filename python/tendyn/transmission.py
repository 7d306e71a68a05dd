"""Python face of the transmission core: routing, kinematics and statics with losses.

Every computation runs in the C++ core (:mod:`tendyn._core`, ``include/tendyn/routing.hpp`` and
``losses.hpp``); this class only allocates the numpy arrays a Python user wants back. Indices are
0-based: transmission ``i`` drives joint ``i`` and crosses joints ``0 … i-1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendyn import _core

MATRIX_NAMES = (
    "joint_from_motor_position",
    "motor_from_joint_position",
    "motor_from_joint_torque",
    "joint_from_motor_torque",
)

_LOSS_FIELDS = ("tau0", "nu", "beta", "bearing_count", "bearing_radius", "bearing_wrap",
                "bearing_alpha", "bearing_beta", "bearing_h0", "bearing_h1", "bearing_n0")


@dataclass(frozen=True)
class StaticsResult:
    """Outcome of one statics call (arrays are copies).

    Attributes
    ----------
    torque_motor : (n,) motor torques C_m [N·m]
    torque_joint : (n,) joint torques τ_J [N·m]
    tension_motor : (n,) tension leaving each motor pulley [N]
    tension : (n, n) tension at joint b after branch b of transmission i [N]
    stuck : (n, n) bool, branch at rest (static friction balances it)
    self_locked : (n,) bool, a self-locking reducer holds a back-driving load
    status : the core's status (Ok or SelfLocked)
    """

    torque_motor: np.ndarray
    torque_joint: np.ndarray
    tension_motor: np.ndarray
    tension: np.ndarray
    stuck: np.ndarray
    self_locked: np.ndarray
    status: _core.Status


class Transmission:
    """n tendon transmissions on an n-joint chain: kinematics (S0 eqs. 1–2) and statics (eqs. 4–12).

    Build it with :meth:`from_arrays` or :meth:`from_device`; the model is validated once.
    """

    def __init__(self, model: _core.TransmissionModel):
        status = model.validate()
        if status != _core.Status.Ok:
            raise ValueError(f"invalid transmission model: {_core.status_message(status)}")
        self.model = model
        self.data = _core.TransmissionData(model)

    # ---- construction ------------------------------------------------------------------------
    @classmethod
    def from_arrays(cls, motor_radius, K, reducer_ratio=None, reducer_efficiency=None,
                    pretension=None, **losses) -> "Transmission":
        """Build from arrays (SI units).

        Parameters
        ----------
        motor_radius : (n,) motor pulley radii r_m [m]
        K : (n, n) lower-triangular transmission matrix [m]; strict lower part = signed idle radii,
            diagonal = generalised driven radius (pulley radius × reducer ratio, S0 footnote 1)
        reducer_ratio : (n,) reducer ratios n_i [-] (default 1: the diagonal is the pulley radius)
        reducer_efficiency : (n,) direct efficiencies η_d in (0, 1] (default 1)
        pretension : (n,) cable pretension [N] (loads the bearings)
        **losses : (n, n) per-branch arrays named as the core fields: tau0 [N], nu [N·s/m],
            beta [-], bearing_count, bearing_radius [m], bearing_wrap [rad], bearing_alpha [m],
            bearing_beta [m], bearing_h0 [N·m], bearing_h1 [N·m·(rad/s)^(-2/3)], bearing_n0 [rad/s]
        """
        r_m = np.asarray(motor_radius, dtype=float)
        K = np.asarray(K, dtype=float)
        n = r_m.size
        if K.shape != (n, n):
            raise ValueError(f"K must be ({n}, {n}) to match motor_radius, got {K.shape}")
        ratio = np.ones(n) if reducer_ratio is None else np.asarray(reducer_ratio, dtype=float)
        if np.any(ratio <= 0):
            raise ValueError("reducer_ratio must be > 0")
        model = _core.TransmissionModel(r_m, np.tril(K, -1), np.diag(K) / ratio, ratio)
        if reducer_efficiency is not None:
            model.reducer_efficiency = np.asarray(reducer_efficiency, dtype=float)
        if pretension is not None:
            model.pretension = np.asarray(pretension, dtype=float)
        for name, value in losses.items():
            if name not in _LOSS_FIELDS:
                raise TypeError(f"unknown loss parameter {name!r}; expected one of {_LOSS_FIELDS}")
            if value is not None:
                setattr(model, name, np.asarray(value, dtype=float))
        return cls(model)

    @classmethod
    def from_device(cls, device) -> "Transmission":
        """Build from a loaded :class:`tendyn.device.Device`."""
        arrays = device.routing_arrays()
        return cls.from_arrays(
            arrays["motor_radius"], arrays["K"], arrays["reducer_ratio"],
            arrays["reducer_efficiency"], arrays["pretension"],
            **{k: arrays[k] for k in _LOSS_FIELDS if k in arrays})

    # ---- properties --------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.model.n

    @property
    def K(self) -> np.ndarray:
        """Transmission matrix [m] (R_m q_m = K q)."""
        return np.array(self.model.K)

    def matrices(self) -> dict[str, np.ndarray]:
        """The four maps a controller needs plus K and R_m (copies)."""
        out = {name: np.array(getattr(self.model, name)) for name in MATRIX_NAMES}
        out["K"] = self.K
        out["R_m"] = np.diag(np.array(self.model.motor_radius))
        return out

    # ---- kinematics --------------------------------------------------------------------------
    def joint_from_motor(self, q_motor) -> np.ndarray:
        """Joint positions [rad] from motor positions [rad] (S0 eqs. 1–2, corrected)."""
        _core.joint_from_motor(self.model, self.data, np.asarray(q_motor, dtype=float))
        return np.array(self.data.q)

    def motor_from_joint(self, q) -> np.ndarray:
        """Motor positions [rad] from joint positions [rad]."""
        _core.motor_from_joint(self.model, self.data, np.asarray(q, dtype=float))
        return np.array(self.data.q_motor)

    def branch_displacements(self, q) -> np.ndarray:
        """Branch displacements S[i, b] [m] at joint positions q [rad]."""
        self.motor_from_joint(q)
        _core.branch_displacements(self.model, self.data)
        return np.array(self.data.S)

    def branch_velocities(self, qd) -> np.ndarray:
        """Branch velocities Ṡ[i, b] [m/s] at joint velocities qd [rad/s]."""
        _core.velocities_from_joint(self.model, self.data, np.asarray(qd, dtype=float))
        return np.array(self.data.Sdot)

    # ---- statics -----------------------------------------------------------------------------
    def _result(self, status) -> StaticsResult:
        d = self.data
        return StaticsResult(np.array(d.torque_motor), np.array(d.torque_joint),
                             np.array(d.tension_motor), np.array(d.tension),
                             np.array(d.stuck, dtype=bool), np.array(d.self_locked, dtype=bool), status)

    def feedforward(self, torque_joint, qd=None, losses: bool = True) -> StaticsResult:
        """Motor torques to command for joint torques wanted at joint velocity qd [rad/s].

        ``losses=False`` gives the lossless statics C_m = R_m K⁻ᵀ τ_J (S0 eq. 5, corrected).
        """
        tj = np.asarray(torque_joint, dtype=float)
        if not losses:
            status = _core.motor_torque_lossless(self.model, self.data, tj)
        else:
            qd = np.zeros(self.n) if qd is None else np.asarray(qd, dtype=float)
            status = _core.motor_torque_feedforward(self.model, self.data, tj, qd)
        return self._result(status)

    def forward(self, torque_motor, qd=None, losses: bool = True) -> StaticsResult:
        """Joint torques delivered by motor torques [N·m] at joint velocity qd [rad/s]."""
        tm = np.asarray(torque_motor, dtype=float)
        if not losses:
            status = _core.joint_torque_lossless(self.model, self.data, tm)
        else:
            qd = np.zeros(self.n) if qd is None else np.asarray(qd, dtype=float)
            status = _core.joint_torque_forward(self.model, self.data, tm, qd)
        return self._result(status)

    def routing_table(self) -> list[dict]:
        """One row per transmission: motor radius, signed radius at every joint, reducer."""
        K = self.K
        rows = []
        for i in range(self.n):
            rows.append({
                "transmission": i + 1,
                "drives_joint": i + 1,
                "motor_radius_m": float(self.model.motor_radius[i]),
                "radius_at_joint_m": [float(K[i, j]) for j in range(i + 1)],
                "driven_radius_m": float(self.model.driven_radius[i]),
                "reducer_ratio": float(self.model.reducer_ratio[i]),
                "reducer_efficiency": float(self.model.reducer_efficiency[i]),
                "generalised_radius_m": float(K[i, i]),
                "joint_per_motor_ratio": float(K[i, i] / self.model.motor_radius[i]),
            })
        return rows
