"""Gravity and friction compensation of the CEA branch from identified parameters (S2 §VII, C46).

S2: "The gravity effect can be compensated by means of a predictive control … the compensation of friction is
more difficult because of its sensitivity to noises and cable wear. A solution consists in implanting
underestimated friction coefficients." The law, per control period, from the motor encoders only:

    q̂ = q_m / N,   q̂̇_m: first-order filtered difference (cut-off DEFAULT_VELOCITY_CUTOFF_HZ, as compensator.hpp),
    τ = Q̂(q̂) + ôffset + k · w ∘ (F̂_v q̂̇ + F̂_c sign(q̂̇)),   w_i = min(1, |q̂̇_m,i| / v_band)   (S2 eqs. 1, 15),
    C_m = τ / N   (a capstan motor torque C reaches the joint as N C),

with Q̂, F̂_v, F̂_c, ôffset from the *identified* base parameters (the regressor of
:class:`tendyn.analysis.operational.OperationalModel`) and k the under-estimation factor. The C++ compensator
(``include/tendyn/compensator.hpp``) covers cable transmissions (losses.hpp); a capstan branch has no cable
routing, so the law above runs in Python here, with the same fade band and velocity filter constants
(:mod:`tendyn.control.compensator`) and the same control-period runner as the L-EXOS runs
(:mod:`tendyn.pipelines.s0_compensation`).

On the twin (capstan springs, motor-side Coulomb/viscous friction, quantised encoders, its *true* parameters):

* **feel** — a hand (spring–damper) drags the handle at constant speed back and forth along a line through the
  natural pose; the force it needs, odd part over the constant-speed segments, is the apparent friction left,
  beside the model prediction Σ_i (F_i,true − k F̂_i)(q̇) · J⁻¹u;
* **passivity** — the work the device does on the hand per closed cycle (≤ 0: the device takes energy);
* **stability** — the hand lets go after the cycle: the handle must come to rest (no limit cycle);
* **gravity** — released at rest at several poses with gravity compensation only, the handle must stay
  (compared with no compensation at all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn import _core
from tendyn.control.compensator import DEFAULT_VELOCITY_BAND, DEFAULT_VELOCITY_CUTOFF_HZ
from tendyn.device import compile_device
from tendyn.results import Result, format_table
from tendyn.sim.model import sim_model

__all__ = ["CapstanCompensator", "CompensationResult", "HandStroke", "HoldRun", "compensation_from_identified",
           "hand_stroke", "hold_run", "DEFAULT_FACTORS"]

DEFAULT_FACTORS = (0.0, 0.5, 0.8, 1.0)
"""Under-estimation factors k of the friction coefficients (0: gravity compensation only)."""


class CapstanCompensator:
    """The compensation law above for a capstan-driven device, from an OperationalModel's base parameters.

    Parameters
    ----------
    model : tendyn.analysis.operational.OperationalModel (its parameters are the identified ones)
    factor : k [-] in [0, 1.5] (friction part; 0 = gravity and offsets only)
    gravity : False leaves gravity and offsets out (k · friction only)
    velocity_band : v_band [rad/s], motor side; velocity_cutoff_hz : velocity filter [Hz]; rate_hz : control rate
    """

    def __init__(self, model, factor: float, gravity: bool = True, velocity_band: float = DEFAULT_VELOCITY_BAND,
                 velocity_cutoff_hz: float = DEFAULT_VELOCITY_CUTOFF_HZ, rate_hz: float = 1000.0):
        if not 0.0 <= factor <= 1.5:
            raise ValueError(f"factor must be in [0, 1.5] (got {factor})")
        self.model, self.factor, self.gravity = model, float(factor), bool(gravity)
        self.ratio = np.asarray(model.ratio, float)
        self.band, self.rate = float(velocity_band), float(rate_hz)
        self.alpha = 1.0 - math.exp(-2 * math.pi * velocity_cutoff_hz / rate_hz) if velocity_cutoff_hz > 0 else 1.0
        na = len(self.ratio)
        self._xg = np.where(np.isin(model.kinds, ("inertial", "offset")), model.x, 0.0)
        self._xf = np.where(np.isin(model.kinds, ("viscous", "coulomb")), model.x, 0.0)
        self._prev = None
        self.qd_motor = np.zeros(na)

    def reset(self) -> None:
        self._prev = None
        self.qd_motor[:] = 0.0

    def joint_torque(self, q, qd_motor) -> np.ndarray:
        """τ [N·m] at joint estimate q [rad] and motor velocity estimate [rad/s]."""
        na = len(self.ratio)
        qd = qd_motor / self.ratio
        W = self.model.regressor(np.vstack([q, q]), np.vstack([np.zeros(na), qd]), np.zeros((2, na)))
        tau = W[0] @ self._xg if self.gravity else np.zeros(na)
        if self.factor > 0:
            w = np.minimum(1.0, np.abs(qd_motor) / self.band) if self.band > 0 else np.ones(na)
            tau = tau + self.factor * w * (W[1] @ self._xf)
        return tau

    def cycle(self, q_motor) -> np.ndarray:
        """Encoder readings [rad] → motor torques [N·m]."""
        qm = np.asarray(q_motor, float)
        if self._prev is not None:
            self.qd_motor += self.alpha * ((qm - self._prev) * self.rate - self.qd_motor)
        self._prev = qm.copy()
        return self.joint_torque(qm / self.ratio, self.qd_motor) / self.ratio


def _setup(compiled, q0, comp, rate_hz, control_hz, seed):
    from tendyn.pipelines.twin_loop import ControlBlock

    sim = sim_model(compiled, rate_hz=rate_hz, control_hz=control_hz)
    data = _core.SimData(sim)
    q0 = np.asarray(q0, float)
    data.reset(q0, seed)
    # springs already deflected by the torque the compensator starts with (a device holding its pose)
    c0 = comp.joint_torque(q0, np.zeros_like(q0)) / comp.ratio if comp is not None else np.zeros_like(q0)
    data.set_motor_position(np.array(sim.ratio) * q0 + c0 / np.array(sim.stiffness_motor))
    return sim, data, ControlBlock(sim)


@dataclass(eq=False)
class HandStroke:
    """A hand dragging the handle at constant speed along ``direction`` (operator frame) and letting go.

    factor : k; speed [m/s]; friction_felt : odd part of the hand force along the line over the constant-speed
    segments [N] (what friction the user still feels); friction_predicted : the model's value at the natural
    pose [N]; bias : even part [N] (gravity/offset left); energy_to_hand : work the device does on the hand over
    the closed cycle [J] (≤ 0 passive); rest_speed : handle speed [m/s] at the end of the release (the link
    rings on the capstan springs); release_ptp : peak-to-peak handle position over the last part of the
    release [m]; release_ptp_start : the same just after the release [m]; stable : it stays under 1 mm and
    does not grow after the release; time, force_along,
    position_along : records (control rate).
    """

    factor: float
    speed: float
    friction_felt: float
    friction_predicted: float
    bias: float
    energy_to_hand: float
    rest_speed: float
    release_ptp: float
    release_ptp_start: float
    stable: bool
    time: np.ndarray = field(repr=False)
    force_along: np.ndarray = field(repr=False)
    position_along: np.ndarray = field(repr=False)


def _stroke_timing(stroke, speed, accel):
    """One way of the stroke [s]: (accelerating time, cruising time at ``speed`` [m/s], whole way T)."""
    t_acc = speed / accel
    t_cruise = max(stroke - accel * t_acc ** 2, 0.0) / speed
    return t_acc, t_cruise, 2 * t_acc + t_cruise


def _stroke_profile(t, stroke, speed, accel):
    """Back-and-forth along a line: out by ``stroke`` [m] then back, trapezoidal speed. (s, v, cruising)."""
    t_acc, t_cruise, T = _stroke_timing(stroke, speed, accel)
    d_acc = 0.5 * accel * t_acc ** 2
    def one(tt):
        if tt <= 0:
            return 0.0, 0.0, False
        if tt < t_acc:
            return 0.5 * accel * tt ** 2, accel * tt, False
        if tt < t_acc + t_cruise:
            return d_acc + speed * (tt - t_acc), speed, tt > t_acc + 0.25 * t_cruise
        if tt < T:
            r = T - tt
            return stroke - 0.5 * accel * r ** 2, accel * r, False
        return stroke, 0.0, False
    if t < T:
        s, v, c = one(t)
        return s, v, (1 if c else 0)
    if t < 2 * T:
        s, v, c = one(t - T)
        return stroke - s, -v, (-1 if c else 0)
    return 0.0, 0.0, 0


def hand_stroke(model, q0, factor: float, *, direction=(1.0, 1.0, 1.0), stroke: float = 0.06, speed: float = 0.05,
                accel: float = 0.5, release: float = 0.6, hand_stiffness: float = 1000.0, hand_damping: float = 10.0,
                rate_hz: float = 10_000.0, control_hz: float = 1_000.0, seed: int = 3, gravity: bool = True) -> HandStroke:
    """One cycle out and back (``stroke`` [m] at ``speed`` [m/s], centred on the natural handle position q0),
    then ``release`` [s] with the hand off; compensator at factor k from the model's (identified) parameters."""
    compiled = model.compiled
    u = np.asarray(direction, float)
    u = u / np.linalg.norm(u)
    comp = CapstanCompensator(model, factor, gravity=gravity, rate_hz=control_hz)
    # start at one end of the stroke so that the cycle is centred on the natural pose
    x_nat = model.position(q0)
    q_start = model.inverse_kinematics(x_nat - 0.5 * stroke * u, q0)
    if q_start is None:
        raise ValueError("the stroke leaves the reachable workspace")
    sim, data, block = _setup(compiled, q_start, comp, rate_hz, control_hz, seed)

    x_start = model.position(q_start)
    T = _stroke_timing(stroke, speed, accel)[2]
    periods = int(round((2 * T + release) * control_hz))
    time = np.arange(periods) / control_hz
    f_along, x_along, tag = np.empty(periods), np.empty(periods), np.zeros(periods, int)
    w_cycle = None
    for s, t in enumerate(time):
        torque_motor = comp.cycle(block.encoders(data))
        q, qd = np.array(data.q), np.array(data.qd)
        x = model.position(q)
        J = model.jacobian(q)
        if t < 2 * T:
            sp, vp, tag[s] = _stroke_profile(t, stroke, speed, accel)
            f = hand_stiffness * (x_start + sp * u - x) + hand_damping * (vp * u - J @ qd)
        else:
            if w_cycle is None:
                w_cycle = data.work_external
            f = np.zeros(3)
        block.run(data, torque_motor, J.T @ f)
        f_along[s], x_along[s] = f @ u, (x - x_nat) @ u
    if w_cycle is None:
        w_cycle = data.work_external
    fwd, back = f_along[tag == 1], f_along[tag == -1]
    felt = 0.5 * (fwd.mean() - back.mean()) if fwd.size and back.size else float("nan")
    bias = 0.5 * (fwd.mean() + back.mean()) if fwd.size and back.size else float("nan")
    window = min(0.15, 0.4 * release)
    early = (time >= 2 * T) & (time < 2 * T + window)
    tail = time >= time[-1] - window
    qd_end = np.array(data.qd)
    rest_speed = float(np.linalg.norm(model.jacobian(np.array(data.q)) @ qd_end))
    ptp = float(np.ptp(x_along[tail]))
    ptp_early = float(np.ptp(x_along[early])) if early.any() else ptp
    # prediction at the natural pose: true friction (device) minus k times the identified one, along u
    qd_u = np.linalg.solve(model.jacobian(q0), speed * u)
    true_f = np.array([d.viscous_joint * v + d.coulomb_joint * np.sign(v) for d, v in zip(model.drives, qd_u)])
    pred = float(np.linalg.solve(model.jacobian(q0).T, true_f - model.friction(qd_u, factor)) @ u)
    # stable: after the hand lets go the handle stays within 1 mm and its residual ringing on the capstan springs
    # (the ~25 Hz link mode, undamped once the motor sticks: Table 2 damping ~ 0, so it neither decays nor grows;
    # its peak-to-peak beats by ~±20 % from window to window) does not grow
    stable = bool(ptp < 1e-3 and ptp <= 1.5 * ptp_early + 2e-5)
    return HandStroke(float(factor), float(speed), float(felt), pred, float(bias), float(-w_cycle), rest_speed, ptp,
                      ptp_early, stable, time, f_along, x_along)


@dataclass(eq=False)
class HoldRun:
    """The handle released at rest at ``q0`` with gravity compensation (``compensated``) or none.

    drift : |x(T) − x(0)| [m]; peak_speed : [m/s]; duration : [s]; offset_mm : the pose's offset from the
    natural pose [mm]; gravity_error : max |Q̂ − Q_true| at q0 over the joints [N·m] (identified vs twin)."""

    offset_mm: tuple
    compensated: bool
    drift: float
    peak_speed: float
    duration: float
    gravity_error: float


def hold_run(model, q0, compensated: bool = True, *, duration: float = 1.0, rate_hz: float = 10_000.0,
             control_hz: float = 1_000.0, seed: int = 5, offset_mm=(0.0, 0.0, 0.0), truth=None) -> HoldRun:
    """Release the handle at rest at q0 [rad] for ``duration`` [s] with gravity (+ offset) compensation from the
    model's parameters (k = 0) or with no motor torque at all."""

    comp = CapstanCompensator(model, 0.0, rate_hz=control_hz) if compensated else None
    sim, data, block = _setup(model.compiled, q0, comp, rate_hz, control_hz, seed)
    x0 = model.position(q0)
    periods = int(round(duration * control_hz))
    peak = 0.0
    zero = np.zeros(len(model.ratio))
    for _ in range(periods):
        tm = comp.cycle(block.encoders(data)) if comp is not None else zero
        block.run(data, tm, zero)
        q, qd = np.array(data.q), np.array(data.qd)
        peak = max(peak, float(np.linalg.norm(model.jacobian(q) @ qd)))
    drift = float(np.linalg.norm(model.position(np.array(data.q)) - x0))
    gerr = float("nan")
    if truth is not None:
        gerr = float(np.max(np.abs(model.gravity(q0) + model.offsets() - truth.gravity(q0) - truth.offsets())))
    return HoldRun(tuple(offset_mm), bool(compensated), drift, peak, float(duration), gerr)


@dataclass(eq=False)
class CompensationResult(Result):
    """C46 on the CEA twin: apparent friction left vs k, passivity, stability, gravity hold.

    ``summary`` (= ``to_dict()``) holds ``strokes`` (per k: friction_felt_N, friction_predicted_N, reduction,
    energy_to_hand_J, stable), ``friction_uncompensated_N``, ``hold`` (per pose, compensated and not),
    ``passive`` and ``stable`` (every k ≤ 1), ``gravity_holds``.
    """

    device: str
    params_source: str
    strokes: list
    holds: list
    direction: tuple
    _panels = 2
    _figsize = (5.5, 4.0)

    @property
    def summary(self) -> dict:
        return self.to_dict()

    def to_dict(self) -> dict:
        base = next((s for s in self.strokes if s.factor == 0.0), None)
        f0 = base.friction_felt if base is not None else float("nan")
        within = [s for s in self.strokes if s.factor <= 1.0]
        comp_holds = [h for h in self.holds if h.compensated]
        return {
            "device": self.device, "params": self.params_source,
            "direction": [float(v) for v in self.direction],
            "friction_uncompensated_N": f0,
            "strokes": [{"factor": s.factor, "speed_m_per_s": s.speed, "friction_felt_N": s.friction_felt,
                         "friction_predicted_N": s.friction_predicted,
                         "reduction": float(1 - s.friction_felt / f0) if f0 == f0 and f0 != 0 else None,
                         "bias_N": s.bias, "energy_to_hand_J": s.energy_to_hand, "rest_speed_m_per_s": s.rest_speed,
                         "release_ptp_start_m": s.release_ptp_start, "release_ptp_m": s.release_ptp,
                         "stable": s.stable} for s in self.strokes],
            "passive": bool(all(s.energy_to_hand <= 0 for s in within)),
            "stable": bool(all(s.stable for s in within)),
            "hold": [{"offset_mm": list(h.offset_mm), "compensated": h.compensated, "drift_m": h.drift,
                      "peak_speed_m_per_s": h.peak_speed, "duration_s": h.duration,
                      "gravity_error_N_m": h.gravity_error} for h in self.holds],
            "gravity_holds": bool(comp_holds and all(h.drift < 1e-3 for h in comp_holds)),
            "max_hold_drift_m": float(max(h.drift for h in comp_holds)) if comp_holds else None,
        }

    def table(self) -> str:
        rows = [(s.factor, s.friction_felt, s.friction_predicted, s.bias, s.energy_to_hand,
                 f"{1e3 * s.release_ptp_start:.3g} → {1e3 * s.release_ptp:.3g}", "yes" if s.stable else "no")
                for s in self.strokes]
        t1 = format_table(("k", "felt friction [N]", "predicted [N]", "bias [N]", "energy to hand [J]",
                           "ringing after release [mm p-p]", "stable"), rows,
                          title=f"{self.device}: friction left with under-estimated coefficients "
                                f"({self.params_source} parameters, C46)")
        t2 = format_table(("pose offset [mm]", "compensation", "drift [mm]", "peak speed [mm/s]", "|ΔQ| [N·m]"),
                          [("/".join(f"{v:g}" for v in h.offset_mm), "gravity" if h.compensated else "none",
                            1e3 * h.drift, 1e3 * h.peak_speed, h.gravity_error) for h in self.holds],
                          title="handle released at rest")
        return t1 + "\n\n" + t2

    reading = ('Left: the hand force while dragging the handle at constant speed, one curve per under-estimation '
               'factor k; right: the friction left against k, felt on the twin and predicted.')

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        for i, s in enumerate(self.strokes):
            axes[0].plot(s.time, s.force_along, lw=0.9, color=f"C{i}", label=f"k = {s.factor:g}")
        axes[0].set_xlabel("time [s]")
        axes[0].set_ylabel("hand force along the stroke [N]")
        axes[0].set_title(f"{self.device}: hand dragging the handle at constant speed", fontsize=9)
        axes[0].legend(fontsize=7)
        axes[0].grid(alpha=0.3)
        if len(axes) > 1:
            k = [s.factor for s in self.strokes]
            axes[1].plot(k, [s.friction_felt for s in self.strokes], "o-", label="felt (twin)")
            axes[1].plot(k, [s.friction_predicted for s in self.strokes], "k--", label="predicted")
            axes[1].set_xlabel("under-estimation factor k [-]")
            axes[1].set_ylabel("apparent friction left [N]")
            axes[1].grid(alpha=0.3)
            axes[1].legend(fontsize=7)


def compensation_from_identified(device, params=None, factors=DEFAULT_FACTORS, quick: bool = False, *,
                                 over=(), q_natural=None, direction=(1.0, 1.0, 1.0), progress=None) -> CompensationResult:
    """C46: gravity and friction compensation of the twin from identified parameters.

    Parameters
    ----------
    device : Device, CompiledDevice or name-resolved device (capstan drives, e.g. ``cea_branch``)
    params : None (the twin's true base parameters), PARAMS.json path, identify document or its list
    factors : under-estimation factors k of the friction part (each in [0, 1])
    quick : shorter strokes and fewer hold poses (tests)
    over : over-compensating factors (> 1, ≤ 1.5) run as well, for contrast (not in ``passive``/``stable``)
    q_natural : natural pose [rad] (default :func:`tendyn.analysis.operational.natural_pose`)
    direction : stroke direction, operator frame
    progress : callable(str) for progress messages

    Returns
    -------
    CompensationResult (``.summary``: the ``compensation`` part of ``tendyn pipeline s2 --json``)
    """
    from tendyn.analysis.operational import OperationalModel, natural_pose

    model = device if isinstance(device, OperationalModel) else OperationalModel(compile_device(device), params)
    truth = OperationalModel(model.compiled)           # the twin's own parameters (only for the reported |ΔQ|)
    q0 = natural_pose(model) if q_natural is None else np.asarray(q_natural, float)
    kw = dict(stroke=0.04, release=0.4) if quick else {}
    strokes = []
    for k in tuple(factors) + tuple(over):
        if progress:
            progress(f"compensation: hand stroke, k = {k:g}")
        strokes.append(hand_stroke(model, q0, float(k), direction=direction, **kw))
    offsets = [(0.0, 0.0, 0.0)] if quick else [(0.0, 0.0, 0.0), (30.0, 0.0, -30.0), (-30.0, 30.0, 30.0)]
    holds = []
    for off in offsets:
        qh = model.inverse_kinematics(model.position(q0) + 1e-3 * np.asarray(off), q0)
        if qh is None:
            continue
        if progress:
            progress(f"compensation: gravity hold at {off} mm")
        dur = 0.5 if quick else 1.0
        holds.append(hold_run(model, qh, True, duration=dur, offset_mm=off, truth=truth))
        holds.append(hold_run(model, qh, False, duration=dur, offset_mm=off, truth=truth))
    source = "true" if params is None and not isinstance(device, OperationalModel) else "identified"
    return CompensationResult(model.device.name, source, strokes, holds, tuple(float(v) for v in direction))
