"""Python face of the transmission core: routing, kinematics and statics with losses.

Every computation runs in the C++ core (:mod:`tendyn._core`, ``include/tendyn/routing.hpp`` and
``losses.hpp``); this class only allocates the numpy arrays a Python user wants back. Indices are
0-based: transmission ``i`` drives joint ``i`` and crosses joints ``0 … i-1`` in a serial routing (S0's); in a
general routing (issue 19) it also wraps joints after ``i`` (``model.last_joint[i]``: differentials), radii are
signed and a diagonal may be zero (docs/device-file.md, "General routing").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from tendyn import _core

MATRIX_NAMES = (
    "joint_from_motor_position",
    "motor_from_joint_position",
    "motor_from_joint_torque",
    "joint_from_motor_torque",
)



class CoreField(NamedTuple):
    """One field of the core transmission model, as the core declares it (``TENDYN_TRANSMISSION_FIELDS`` in
    ``include/tendyn/routing.hpp``): name, dims (1: per transmission, 2: per branch), SI unit, meaning."""

    name: str
    dims: int
    unit: str
    doc: str


MODEL_FIELDS = tuple(CoreField(*f) for f in _core.TransmissionModel.fields())
"""The fields of the core model, in the core's order, from the core itself (this face sits below
:mod:`tendyn.device`, whose schema tables add each field's device-file route and default; a test keeps the two in
step)."""

LOSS_FIELDS = tuple(f.name for f in MODEL_FIELDS if f.dims == 2 and f.name != "K")
"""The per-branch loss and bearing fields accepted by :meth:`Transmission.from_arrays` (derived)."""


# ---- input checks (a clear message instead of a binding signature dump) ----------------------------

def _numeric_array(x, name: str, what: str) -> np.ndarray:
    """``x`` as a float array; strings, booleans and non-numeric objects are refused."""
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{name} must be {what} (got a string {x!r})")
    try:
        a = np.asarray(x)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name} must be {what} (got a ragged or invalid sequence: {exc})") from None
    if a.dtype.kind == "O":  # mixed objects: accept only real numbers (never str or bool)
        flat = a.ravel().tolist()
        bad = next((v for v in flat if isinstance(v, (str, bytes, bool, np.bool_))
                    or not isinstance(v, (int, float, np.integer, np.floating))), None)
        if bad is not None:
            raise TypeError(f"{name} must be {what} (got an entry of type {type(bad).__name__}: {bad!r})")
        a = a.astype(float)
    elif a.dtype.kind not in "iuf":
        kind = {"U": "strings", "S": "bytes", "b": "booleans", "c": "complex numbers"}.get(a.dtype.kind, str(a.dtype))
        raise TypeError(f"{name} must be {what} (got {kind})")
    return a.astype(float, copy=False)


def _finite(a: np.ndarray, name: str, what: str) -> np.ndarray:
    if not np.all(np.isfinite(a)):
        idx = tuple(int(k) for k in np.argwhere(~np.isfinite(a))[0])
        where = idx[0] if len(idx) == 1 else idx
        raise ValueError(f"{name} must be {what} (got NaN or Inf at index {where})")
    return a


def as_vector(x, name: str, n: int) -> np.ndarray:
    """``x`` as a (n,) float array, or a ValueError / TypeError naming ``name``, the wanted shape and what was
    given: ``q_motor must be a 1-D array of 4 finite floats (got shape (4, 4))``."""
    what = f"a 1-D array of {n} finite floats"
    a = _numeric_array(x, name, what)
    if a.shape != (n,):
        raise ValueError(f"{name} must be {what} (got shape {a.shape})")
    return _finite(a, name, what)


def as_matrix(x, name: str, rows: int, cols: int) -> np.ndarray:
    """``x`` as a (rows, cols) float array, or an error naming ``name`` and the shapes."""
    what = f"a ({rows}, {cols}) array of finite floats"
    a = _numeric_array(x, name, what)
    if a.shape != (rows, cols):
        raise ValueError(f"{name} must be {what} (got shape {a.shape})")
    return _finite(a, name, what)


def without_losses(arrays: dict) -> dict:
    """A copy of routing arrays with every loss switched off: the loss and bearing fields and the reducer efficiency
    left out, so the core gives each its lossless default (no friction, no bearings, η_d = 1). Routing, reducer
    ratios and pretension stay."""
    return {k: v for k, v in arrays.items() if k not in LOSS_FIELDS and k != "reducer_efficiency"}


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
    status : the core's status (Ok, SelfLocked, or NotConverged when a coupled block's iteration hit its cap)
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

    Build it with :meth:`from_arrays`, :meth:`from_device` or :meth:`load`; the core model is validated
    once, when it is built, and is read-only afterwards (its fields are read-only numpy views; assigning one
    raises AttributeError). To change a parameter build a new Transmission. An invalid model raises
    ValueError naming the field and its 0-based index: ``beta[2,1] = 1.5: must be < 1``.
    """

    def __init__(self, model: _core.TransmissionModel):
        if not isinstance(model, _core.TransmissionModel):
            raise TypeError(f"model must be a tendyn._core.TransmissionModel (got {type(model).__name__})")
        report = _core.validate_report(model)
        if report:
            raise ValueError(f"invalid transmission model: {report[0]}")
        self._model = model
        self._data = _core.TransmissionData(model)

    @property
    def model(self) -> _core.TransmissionModel:
        """The core model (read-only)."""
        return self._model

    @property
    def data(self) -> _core.TransmissionData:
        """The preallocated core data (outputs of the last call)."""
        return self._data

    # ---- construction ------------------------------------------------------------------------
    @classmethod
    def from_arrays(cls, motor_radius, K, reducer_ratio=None, reducer_efficiency=None,
                    pretension=None, **losses) -> "Transmission":
        """Build from arrays (SI units), validated once.

        Parameters
        ----------
        motor_radius : (n,) motor pulley radii r_m [m]
        K : (n, n) invertible transmission matrix [m]; [i, j] = signed radius of the pulley of joint j cable i
            wraps (lower-triangular for a serial routing; after the diagonal for a differential), diagonal =
            generalised driven radius (pulley radius × reducer ratio, S0 footnote 1; signed, may be 0)
        reducer_ratio : (n,) reducer ratios n_i [-] (default 1: the diagonal is the pulley radius)
        reducer_efficiency : (n,) direct efficiencies η_d in (0, 1] (default 1)
        pretension : (n,) cable pretension [N] (loads the bearings)
        **losses : (n, n) per-branch arrays named as the core fields (:data:`LOSS_FIELDS`): tau0 [N],
            nu [N·s/m], beta [-], bearing_count [-], bearing_radius [m], bearing_wrap [rad],
            bearing_static_coefficient [m], bearing_dynamic_coefficient [m], bearing_h0 [N·m],
            bearing_h1 [N·m·(rad/s)^(-2/3)], bearing_n0 [rad/s]; absent = default (lossless, no bearing)

        Raises
        ------
        TypeError
            A string, boolean or other non-number where numbers belong; an unknown loss name.
        ValueError
            A wrong shape or a non-finite value (naming the argument), or a model the core rejects
            (naming the field and its 0-based index).
        """
        r_m = _numeric_array(motor_radius, "motor_radius", "a 1-D array of finite floats [m]")
        if r_m.ndim != 1 or r_m.size == 0:
            raise ValueError(f"motor_radius must be a 1-D array of finite floats [m] (got shape {r_m.shape})")
        n = r_m.size
        _finite(r_m, "motor_radius", f"a 1-D array of {n} finite floats")
        K = as_matrix(K, "K", n, n)
        ratio = np.ones(n) if reducer_ratio is None else as_vector(reducer_ratio, "reducer_ratio", n)
        if np.any(ratio <= 0):
            raise ValueError(f"reducer_ratio must be > 0 (got {ratio.tolist()})")
        arrays = {"motor_radius": r_m, "K": K, "driven_radius": np.diag(K) / ratio, "reducer_ratio": ratio}
        if reducer_efficiency is not None:
            arrays["reducer_efficiency"] = as_vector(reducer_efficiency, "reducer_efficiency", n)
        if pretension is not None:
            arrays["pretension"] = as_vector(pretension, "pretension", n)
        for name, value in losses.items():
            if name not in LOSS_FIELDS:
                raise TypeError(f"unknown loss parameter {name!r}; expected one of {LOSS_FIELDS}")
            if value is not None:
                arrays[name] = as_matrix(value, name, n, n)
        return cls(_core.TransmissionModel(arrays))

    @classmethod
    def from_device(cls, device, losses: bool = True) -> "Transmission":
        """Build from a loaded :class:`tendyn.device.Device`; ``losses=False`` gives the same routing with
        every loss off (:func:`without_losses`). An N+1 device is refused (DeviceError: its K is not square)."""
        arrays = device.square_routing_arrays("the transmission model (statics with losses)")
        if not losses:
            arrays = without_losses(arrays)
        return cls.from_arrays(
            arrays["motor_radius"], arrays["K"], arrays["reducer_ratio"],
            arrays.get("reducer_efficiency"), arrays["pretension"],
            **{k: arrays[k] for k in LOSS_FIELDS if k in arrays})

    @classmethod
    def load(cls, path) -> "Transmission":
        """Read a model file written by :meth:`export` (the C++ reader of ``include/tendyn/model_file.hpp``;
        ValueError names the file, line and field)."""
        return cls(_core.load_transmission_model(str(path)))

    def export(self, path) -> None:
        """Write the complete model (routing, losses, bearings) as a model file, atomically.

        The C ABI (``tendyn_transmission_load``) and C++ (``tendyn::load_transmission_model``) read it back
        bit for bit, so a controller embeds this exact model. Format: ``include/tendyn/model_file.hpp``.
        """
        _core.save_transmission_model(self._model, str(path))

    def to_dict(self) -> dict[str, np.ndarray]:
        """Every core field as a numpy array (copies), keyed and ordered as :data:`MODEL_FIELDS`."""
        return {f.name: np.array(getattr(self._model, f.name)) for f in MODEL_FIELDS}

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
        _core.joint_from_motor(self._model, self._data, as_vector(q_motor, "q_motor", self.n))
        return np.array(self._data.q)

    def motor_alone_joint_speeds(self, i: int, speed: float) -> np.ndarray:
        """Joint speeds [rad/s] while motor ``i`` (0-based) alone turns at ``speed`` [rad/s], the others held:
        q̇ = K⁻¹ R_m e_i v (S0 eqs. 1–2 and 14, corrected: ERRATA; the core's joint_from_motor_position). The one
        definition of "motor i alone" the passivity bound and the export summary read."""
        if not 0 <= i < self.n:
            raise ValueError(f"motor index {i} out of range 0..{self.n - 1}")
        return np.asarray(self._model.joint_from_motor_position, float)[:, i] * float(speed)

    def motor_from_joint(self, q) -> np.ndarray:
        """Motor positions [rad] from joint positions [rad]."""
        _core.motor_from_joint(self._model, self._data, as_vector(q, "q", self.n))
        return np.array(self._data.q_motor)

    def branch_displacements(self, q) -> np.ndarray:
        """Branch displacements ``S[i, b]`` [m] at joint positions q [rad]."""
        self.motor_from_joint(q)
        _core.branch_displacements(self.model, self.data)
        return np.array(self.data.S)

    def branch_velocities(self, qd) -> np.ndarray:
        """Branch velocities ``Ṡ[i, b]`` [m/s] at joint velocities qd [rad/s]."""
        _core.velocities_from_joint(self._model, self._data, as_vector(qd, "qd", self.n))
        return np.array(self.data.Sdot)

    # ---- statics -----------------------------------------------------------------------------
    def _result(self, status) -> StaticsResult:
        d = self.data
        return StaticsResult(np.array(d.torque_motor), np.array(d.torque_joint),
                             np.array(d.tension_motor), np.array(d.tension),
                             np.array(d.stuck, dtype=bool), np.array(d.self_locked, dtype=bool), status)

    def feedforward(self, torque_joint, qd=None, losses: bool = True) -> StaticsResult:
        """Motor torques to command for joint torques wanted at joint velocity qd [rad/s].

        Parameters
        ----------
        torque_joint : (n,) joint torques wanted τ_J [N·m]
        qd : (n,) joint velocity [rad/s] (default 0: every branch at rest)
        losses : False gives the lossless statics C_m = R_m K⁻ᵀ τ_J (S0 eq. 5, corrected)
        """
        tj = as_vector(torque_joint, "torque_joint", self.n)
        if not losses:
            status = _core.motor_torque_lossless(self.model, self.data, tj)
        else:
            qd = np.zeros(self.n) if qd is None else as_vector(qd, "qd", self.n)
            status = _core.motor_torque_feedforward(self.model, self.data, tj, qd)
        return self._result(status)

    def forward(self, torque_motor, qd=None, losses: bool = True) -> StaticsResult:
        """Joint torques delivered by motor torques at joint velocity qd.

        Parameters
        ----------
        torque_motor : (n,) motor torques C_m [N·m]
        qd : (n,) joint velocity [rad/s] (default 0)
        losses : False gives the lossless statics τ_J = Kᵀ R_m⁻¹ C_m
        """
        tm = as_vector(torque_motor, "torque_motor", self.n)
        if not losses:
            status = _core.joint_torque_lossless(self.model, self.data, tm)
        else:
            qd = np.zeros(self.n) if qd is None else as_vector(qd, "qd", self.n)
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
