"""The real-time compensator (``include/tendyn/compensator.hpp``) from a device and its identified friction.

From motor encoder readings and the wanted joint torques (or end-effector force) one cycle computes the motor
torques that also cover gravity and the transmission losses, direction of power flow included (S0 §IV-B,
feedforward β(q̄) = friction + gravity; C10, C46):

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> comp = Compensator.from_device(load_device(bundled("lexos")), underestimation=0.9)
>>> comp.cycle([0.0, 0.0, 0.0, 0.0]).shape
(4,)

Every computation runs in the core; this class only builds the model and allocates what a Python user gets
back. :meth:`Compensator.export` writes the model file a C controller loads with ``tendyn_compensator_load``
(format: ``include/tendyn/compensator_file.hpp``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tendyn import _core
from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.device.closed_loop import end_effector_point
from tendyn.control.transmission_losses import device_transmission, transmission_with_friction
from tendyn.transmission import as_vector

__all__ = ["Compensator", "chain_model", "device_line_problem", "device_transmission", "end_effector_point",
           "transmission_with_friction",
           "DEFAULT_UNDERESTIMATION", "DEFAULT_VELOCITY_BAND", "DEFAULT_VELOCITY_CUTOFF_HZ",
           "IDENTIFIED_UNDERESTIMATION"]

DEFAULT_UNDERESTIMATION = 0.9
"""k [-]: friction compensated with under-estimated coefficients (C46), 10 % below the model."""
IDENTIFIED_UNDERESTIMATION = 0.7
"""k [-] for a compensator built from identified friction (``tendyn export compensator``): identification errs by a
few per cent, friction drifts with temperature and wear, and an over-estimate makes a haptic device active, so
S2's 20–30 % margin (C46) is kept."""
DEFAULT_VELOCITY_BAND = 0.5
"""v_band [rad/s], motor side: below it the friction feedforward fades to zero (2 % of a slow 25 rad/s move)."""
DEFAULT_VELOCITY_CUTOFF_HZ = 30.0
"""First-order velocity filter cut-off [Hz] (encoder quantisation noise at 1 kHz vs. phase lag)."""


def device_line_problem(name: str) -> str | None:
    """Why ``name`` cannot be the ``device`` line of a compensator file (None if it can): the file is line based,
    ``#`` starts a comment and the rest of the line is read without its outer spaces, so a name must be a name
    (:func:`tendyn.text.name_problem`: no newline, no control character) without ``#`` and without outer spaces,
    or it would not read back as itself."""
    from tendyn.text import name_problem

    problem = name_problem(name)
    if problem:
        return problem
    if "#" in name:
        return "'#' starts a comment in that line-based file"
    if name != name.strip():
        return "a leading or trailing space is not kept by that line-based file"
    return None


def chain_model(device: Device | CompiledDevice) -> Any:
    """The core :class:`tendyn._core.ChainModel` (kinematics + gravity, no Pinocchio) of a serial device,
    from the same joint frames as its Pinocchio model. A closed-loop tree (σ = 2 cut frames, passive joints)
    keeps every tree joint and gets its active map q = L q_a + c (``active_map``, ``active_offset``): the
    compensator then sees the gravity Lᵀ g(q) and the Jacobian J L at the actuated joints (virtual work)."""
    compiled = compile_device(device)
    frames = compiled.joint_frames
    c = _core.ChainModel(len(frames))
    c.gravity = np.asarray(compiled.device.kinematics.gravity, float)
    c.parent = np.array([f.parent - 1 for f in frames], dtype=np.int32)
    c.rotation = [np.array(f.placement[:3, :3], float) for f in frames]
    c.translation = [np.array(f.placement[:3, 3], float) for f in frames]
    c.axis = [np.asarray(f.axis, float) for f in frames]
    c.prismatic = np.array([1 if f.prismatic else 0 for f in frames], dtype=np.int32)
    c.mass = np.array([f.mass for f in frames], float)
    c.com = [np.asarray(f.com, float) for f in frames]
    c.ee_joint, c.ee_point = end_effector_point(compiled)
    L, offset = compiled.active_map
    if L.shape[0] != L.shape[1] or not np.array_equal(L, np.eye(L.shape[0])) or np.any(offset != 0):
        c.active_map = np.asarray(L, float)
        c.active_offset = np.asarray(offset, float)
    problem = c.first_issue()
    if problem:
        raise ValueError(f"{compiled.name}: chain model: {problem}")
    return c


def _passivity(compiled: CompiledDevice, passivity, friction, rate_hz: float) -> Any:
    """The PassivityModel of :meth:`Compensator.from_device`'s ``passivity`` argument."""
    from tendyn.control.passivity import passivity_model

    if passivity is None or passivity is False:
        return _core.PassivityModel()
    if isinstance(passivity, _core.PassivityModel):
        return passivity
    options = {} if passivity is True else dict(passivity)
    options.setdefault("friction", friction)
    options.setdefault("rate_hz", rate_hz)
    return passivity_model(compiled, **options)


def _tracking(tracking) -> Any:
    """The FrictionTrackingModel of :meth:`Compensator.from_device`'s ``tracking`` argument."""
    if isinstance(tracking, _core.FrictionTrackingModel):
        return tracking
    t = _core.FrictionTrackingModel()
    if tracking is None or tracking is False:
        return t
    t.enabled = True
    for key, value in ({} if tracking is True else dict(tracking)).items():
        if key == "enabled" or not hasattr(t, key):
            raise TypeError(f"tracking: unknown setting {key!r}")
        setattr(t, key, float(value))
    problem = t.first_issue()
    if problem:
        raise ValueError(problem)
    return t


class Compensator:
    """Gravity + transmission-loss compensator on the C++ core (one model, its preallocated data).

    Build it with :meth:`from_device` or :meth:`load`. The model is validated once and is read-only
    afterwards; for other settings build a new one (:meth:`with_settings`).
    """

    def __init__(self, model: Any):
        if not isinstance(model, _core.CompensatorModel):
            raise TypeError(f"model must be a tendyn._core.CompensatorModel (got {type(model).__name__})")
        problem = model.first_issue()
        if problem:
            raise ValueError(f"invalid compensator model: {problem}")
        self._model = model
        self._data = _core.CompensatorData(model)

    # ---- construction ------------------------------------------------------------------------
    @classmethod
    def from_device(cls, device: Device | CompiledDevice, friction=None, shares=None,
                    underestimation: float = DEFAULT_UNDERESTIMATION,
                    velocity_band: float = DEFAULT_VELOCITY_BAND,
                    velocity_cutoff_hz: float = DEFAULT_VELOCITY_CUTOFF_HZ,
                    rate_hz: float = 1000.0, passivity=None, tracking=None) -> "Compensator":
        """Compensator of a serial (or closed-loop tree) device driven by cables or capstan ``[[drives]]``
        (one-branch transmissions: :func:`device_transmission`).

        Parameters
        ----------
        friction : None, or identified friction: FRICTION.json (path or dict), ``tendyn decompose --json``
            output, or per-branch arrays (:func:`tendyn.ident.loss_model.identified_losses`). It replaces every
            loss term of the device file (one loss model at a time); the model records each term's source.
            None uses the device file's losses.
        shares : loss shares (p, p') or a ``tendyn.shares/1`` file for decomposing FRICTION.json over the
            branches (default: from the construction)
        underestimation : k [-] in [0, 1.5], scales the friction part (0: gravity compensation only)
        velocity_band : v_band [rad/s], motor side; the friction feedforward fades linearly to zero below it
        velocity_cutoff_hz : first-order velocity-filter cut-off [Hz] (0: raw difference)
        rate_hz : control rate [Hz]
        passivity : None (off), True, a mapping of :func:`tendyn.control.passivity.passivity_model` options
            (``friction`` — the reference friction of the certified dissipation bound, by default the same
            ``friction`` as the compensator's —, ``margin``, ``reserve``, ``damping_max``) or a
            ``_core.PassivityModel``: the passivity observer and controller at the motor ports
        tracking : None (off), True (defaults), a mapping of ``_core.FrictionTrackingModel`` fields
            (``forgetting``, ``velocity_min``, ``acceleration_max``, ``scale_min``, ``scale_max``,
            ``covariance_max``) or a ``_core.FrictionTrackingModel``: online friction tracking (RLS)
        """
        from tendyn.ident.calibrated import unwrap

        device, friction = unwrap(device, friction)     # a calibrated device: its loss model, built once
        compiled = compile_device(device)
        m = _core.CompensatorModel()
        if friction is None:
            m.transmission = device_transmission(compiled).model
        else:
            from tendyn.ident.loss_model import identified_losses

            losses = friction = identified_losses(compiled, friction, shares)   # read once: the passivity bound too
            m.transmission = losses.transmission(compiled.device).model
            m.loss_source = losses.source_list()
            m.friction_source = losses.origin
        m.chain = chain_model(compiled)
        m.underestimation = float(underestimation)
        m.velocity_band = float(velocity_band)
        m.velocity_cutoff_hz = float(velocity_cutoff_hz)
        m.rate_hz = float(rate_hz)
        m.passivity = _passivity(compiled, passivity, friction, m.rate_hz)
        m.tracking = _tracking(tracking)
        m.device = compiled.name
        return cls(m)

    @classmethod
    def load(cls, path, expected_device: str | None = None) -> "Compensator":
        """Read a compensator model file (ValueError names the file, line and field)."""
        return cls(_core.load_compensator_model(str(path), expected_device or ""))

    def with_settings(self, **settings) -> "Compensator":
        """A new compensator with the same transmission and chain and other settings (underestimation,
        velocity_band, velocity_cutoff_hz, rate_hz, passivity: a ``_core.PassivityModel`` or None for off,
        tracking: as in :meth:`from_device`)."""
        m = _core.CompensatorModel()
        m.transmission, m.chain, m.device = self._model.transmission, self._model.chain, self._model.device
        if "passivity" in settings:
            p = settings.pop("passivity")
            m.passivity = p if p is not None else _core.PassivityModel()
        else:
            m.passivity = self._model.passivity
        m.tracking = _tracking(settings.pop("tracking")) if "tracking" in settings else self._model.tracking
        m.loss_source, m.friction_source = self._model.loss_source, self._model.friction_source
        for key in ("underestimation", "velocity_band", "velocity_cutoff_hz", "rate_hz"):
            value = settings.pop(key, getattr(self._model, key))
            setattr(m, key, float(value))
        if settings:
            raise TypeError(f"unknown settings {sorted(settings)}")
        return Compensator(m)

    def export(self, path) -> None:
        """Write the compensator model file atomically (read by ``tendyn_compensator_load``). ValueError (nothing
        written) when the device name cannot be one ``device`` line of the file: :func:`device_line_problem`."""
        problem = device_line_problem(self.device)
        if problem:
            raise ValueError(f"{path}: device name {self.device!r} cannot be written in a compensator file: {problem}")
        _core.save_compensator_model(self._model, str(path))

    def text(self) -> str:
        """The model file's text."""
        return _core.compensator_model_text(self._model)

    # ---- properties --------------------------------------------------------------------------
    @property
    def model(self) -> Any:
        return self._model

    @property
    def data(self) -> Any:
        return self._data

    @property
    def n(self) -> int:
        return self._model.transmission.n

    @property
    def device(self) -> str:
        return self._model.device

    @property
    def loss_sources(self) -> dict:
        """Source of each loss term: {"tau0": "device" | "identified" | "none", "nu": …, "beta": …,
        "bearings": …, "reducer_efficiency": …} (the model file's ``section losses``)."""
        from tendyn.ident.loss_model import LOSS_TERMS

        return dict(zip(LOSS_TERMS, self._model.loss_source))

    # ---- cycles ------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the velocity history and the observed energy (the next cycle starts at rest) and go back to
        the identified friction (tracked scales 1); ``data.restart()`` keeps the tracked friction."""
        self._data.reset()

    def cycle(self, q_motor, torque_joint=None) -> np.ndarray:
        """One cycle: encoder readings q_motor [rad] and joint torques wanted on top of gravity [N·m]
        (default 0) → motor torques to command [N·m] (a copy; ``data`` holds the rest, ``compute_time`` [s])."""
        qm = as_vector(q_motor, "q_motor", self.n)
        tj = np.zeros(self.n) if torque_joint is None else as_vector(torque_joint, "torque_joint", self.n)
        _core.compensator_cycle(self._model, self._data, qm, tj)
        return np.array(self._data.torque_motor)

    def cycle_force(self, q_motor, force_ee) -> np.ndarray:
        """One cycle for an end-effector force [N] (base frame): τ_wanted = Jᵀ F."""
        qm = as_vector(q_motor, "q_motor", self.n)
        f = as_vector(force_ee, "force_ee", 3)
        _core.compensator_cycle_force(self._model, self._data, qm, f)
        return np.array(self._data.torque_motor)
