"""Online friction tracking on the twin with its friction drifting (friction_tracking.hpp, C46 beyond the paper).

The twin's transmission losses (τ_0 and ν of every branch) drift as ``1 + drift · sin(2π t / drift_period)`` —
the twin option of :class:`FrictionDrift`, friction changing with temperature, wear and pretension over minutes —
while the device runs a self-test: a joint-space PD controller (gains from the device's own chain, see
:func:`self_test_run`) tracks slow sinusoids about the middle of each joint's range, its joint torques going
through the compensator as the wanted torques (so the compensator adds gravity and its — tracked — friction). No
hand touches the device, so the tracker is active; it never reads the twin's losses.

:func:`self_test_run` returns the tracked scales over time next to the twin's true drift factor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendyn.results import Result, format_table

__all__ = ["FrictionDrift", "TrackingRun", "scale_twin_friction", "self_test_run", "stroke_reference"]


@dataclass(frozen=True)
class FrictionDrift:
    """Twin option: the branch losses τ_0 and ν scaled by ``1 + amplitude · sin(2π t / period + phase)``,
    updated every ``update`` seconds (amplitude [-], period [s], phase [rad], update [s])."""

    amplitude: float = 0.3
    period: float = 120.0
    phase: float = 0.0
    update: float = 0.05

    def factor(self, t) -> np.ndarray | float:
        return 1.0 + self.amplitude * np.sin(2 * np.pi * np.asarray(t, float) / self.period + self.phase)

    def apply(self, sim, base, t: float) -> float:
        """Scale the twin's losses to the factor at t (:func:`scale_twin_friction`); returns the factor."""
        f = float(self.factor(t))
        scale_twin_friction(sim, base, f)
        return f


def scale_twin_friction(sim, base, factor: float) -> None:
    """Set the twin's transmission to ``base`` (a :class:`tendyn.transmission.Transmission`) with its branch
    losses τ_0 and ν multiplied by ``factor`` [-] (β, η_d and the bearings kept)."""
    from tendyn.transmission import Transmission

    a = base.to_dict()
    losses = {k: a[k] for k in a if k == "beta" or k.startswith("bearing_")}
    sim.tendon = Transmission.from_arrays(a["motor_radius"], a["K"], a["reducer_ratio"], a["reducer_efficiency"],
                                          a["pretension"], tau0=factor * a["tau0"], nu=factor * a["nu"], **losses).model
    sim.finalize()      # the viscous matrices and friction sites derive from the losses


@dataclass(eq=False)
class TrackingRun(Result):
    """Tracked scales against the twin's drift.

    Attributes
    ----------
    device : name
    time : (samples,) [s]; truth : (samples,) the twin's drift factor [-]
    scale_constant, scale_viscous : (samples, n) tracked scales [-]
    updates : (n,) RLS updates per transmission
    """

    device: str
    time: np.ndarray
    truth: np.ndarray
    scale_constant: np.ndarray
    scale_viscous: np.ndarray
    updates: np.ndarray

    def error(self, after: float = 0.0) -> np.ndarray:
        """Largest relative error |σ / truth − 1| per transmission after ``after`` seconds, max of both
        scales [-]."""
        keep = self.time >= after
        t = self.truth[keep, None]
        return np.maximum(np.abs(self.scale_constant[keep] / t - 1).max(axis=0),
                          np.abs(self.scale_viscous[keep] / t - 1).max(axis=0))

    reading = ('The friction scales tracked online (one colour per transmission, solid Coulomb, dashed viscous) '
               "against the twin's drifting friction factor (black): the closer they follow it, the better the "
               'tracking.')

    def _draw(self, ax) -> None:
        ax.plot(self.time, self.truth, color="k", lw=2.0, label="twin's friction factor")
        for i in range(self.scale_constant.shape[1]):
            ax.plot(self.time, self.scale_constant[:, i], lw=0.8, label=f"σ_c, transmission {i + 1}")
            ax.plot(self.time, self.scale_viscous[:, i], lw=0.8, ls="--", label=f"σ_v, transmission {i + 1}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("friction scale [-]")
        ax.set_title(f"{self.device}: friction tracked online (RLS) against a drifting twin")
        ax.legend(fontsize=6, ncol=2)

    def to_dict(self) -> dict:
        return {"device": self.device, "duration_s": float(self.time[-1]), "updates": self.updates.tolist(),
                "max_relative_error_after_10s": self.error(10.0).tolist()}

    def table(self) -> str:
        rows = [(i + 1, int(self.updates[i]), 100 * e) for i, e in enumerate(self.error(10.0))]
        return format_table(("transmission", "updates", "max error after 10 s [%]"), rows,
                            title=f"{self.device}: online friction tracking")


def _joint_inertia(compiled, q) -> np.ndarray:
    """Diagonal of the joint-space mass matrix at q [kg·m²] (Pinocchio CRBA)."""
    import pinocchio as pin

    data = compiled.pinocchio_model.createData()
    return np.diag(pin.crba(compiled.pinocchio_model, data, np.asarray(q, float))).copy()


def stroke_reference(q0, amplitude, speeds, duration: float, rate_hz: float, blend: float = 0.15):
    """Self-test reference [rad], [rad/s] at ``rate_hz``: each joint strokes between q0 ± amplitude at constant
    speeds cycling through ``speeds[j]`` (a list per joint, [rad/s]), reversals blended over ``blend`` seconds
    (moving average), so most samples are quasi-static at several speeds (Coulomb and viscous apart)."""
    q0, amplitude = np.asarray(q0, float), np.asarray(amplitude, float)
    n, steps = len(q0), int(round(duration * rate_hz)) + 1
    t = np.arange(steps) / rate_hz
    q = np.empty((steps, n))
    width = max(1, int(round(blend * rate_hz)))
    kernel = np.ones(width) / width
    for j in range(n):
        knots_t, knots_q, now, k, side = [0.0], [q0[j]], 0.0, 0, 1.0
        first = True
        while now < duration + 2 * blend:
            target = q0[j] + side * amplitude[j]
            dist = abs(target - knots_q[-1])
            now += dist / speeds[j][k % len(speeds[j])]
            knots_t.append(now)
            knots_q.append(target)
            k += 0 if first else 1
            first, side = False, -side
        raw = np.interp(np.arange(steps + width) / rate_hz, knots_t, knots_q)
        q[:, j] = np.convolve(raw, kernel, mode="valid")[:steps]
    qd = np.gradient(q, 1.0 / rate_hz, axis=0)
    return t, q, qd


def self_test_run(device, *, duration: float = 120.0, drift: FrictionDrift | None = FrictionDrift(period=240.0),
                  amplitude: float = 0.3, speeds=None, motor_speeds=(6.0, 16.0, 10.0), bandwidth_hz: float = 4.0,
                  compensator=None, tracking=True, rate_hz: float = 10_000.0, control_hz: float = 1_000.0,
                  sample_every: float = 0.1, seed: int = 7) -> TrackingRun:
    """The self-test of the module docstring for ``duration`` [s]: joint j strokes about the middle of its range,
    ±``amplitude`` [rad] (at most 40 % of the range), at the joint speeds ``speeds`` [rad/s] in turn, shifted by
    one per joint (:func:`stroke_reference`); by default the speeds that run the joint's own motor at
    ``motor_speeds`` [rad/s] (joint speed = motor speed / the joint's motor-from-joint ratio), so every motor
    sweeps the speeds the tracked line is used at on both sides of 10 rad/s, whatever its ratio (with one set of
    joint speeds for all, L-EXOS motor 3, ratio 11.25 against 40, ran at 2.7–5.8 rad/s, half of it under
    velocity_min, and its viscous scale was extrapolated: 7.6 % off at 10 rad/s); under a joint PD
    whose gains give each joint ``bandwidth_hz`` (damping ratio 0.7) on the diagonal of the joint-space mass
    matrix at q0 (Pinocchio CRBA); ``compensator`` (a :class:`tendyn.control.Compensator`, tracking on) or one built from the device
    with ``tracking`` settings. The compensator object keeps its tracked state (use it afterwards)."""
    from tendyn import _core
    from tendyn.control import Compensator
    from tendyn.device import compile_device
    from tendyn.pipelines.twin_loop import ControlBlock as _Block, reset_at as _reset
    from tendyn.sim.model import sim_model

    compiled = compile_device(device)
    comp = compensator or Compensator.from_device(compiled, rate_hz=control_hz, tracking=tracking)
    if not comp.model.tracking.enabled:
        raise ValueError("the compensator has no online friction tracking")
    control_hz = comp.model.rate_hz
    sim = sim_model(compiled, rate_hz=rate_hz, control_hz=control_hz)
    base = compiled.transmission
    data = _core.SimData(sim)
    joints = compiled.device.kinematics.joints
    n = len(joints)
    q0 = np.array([0.5 * (j.lower + j.upper) for j in joints])
    amp = np.minimum(amplitude, 0.4 * np.array([j.upper - j.lower for j in joints]))
    if speeds is None:
        ratio = np.abs(np.diag(np.asarray(base.matrices()["motor_from_joint_position"])))
        per_joint = [[v / ratio[j] for v in motor_speeds] for j in range(n)]
    else:
        per_joint = [list(speeds)] * n
    _, q_ref_all, qd_ref_all = stroke_reference(q0, amp, [sp[j % len(sp):] + sp[:j % len(sp)]
                                                          for j, sp in enumerate(per_joint)], duration, control_hz)
    inertia = _joint_inertia(compiled, q0)
    wn = 2 * np.pi * bandwidth_hz
    kp, kd = inertia * wn ** 2, 2 * 0.7 * inertia * wn
    _reset(sim, data, q0, seed)
    block = _Block(sim)
    comp.data.tracking_active = True
    steps = int(round(duration * control_hz))
    every = max(1, int(round(sample_every * control_hz)))
    drift_every = max(1, int(round((drift.update if drift else duration) * control_hz)))
    times, truth, sc, sv = [], [], [], []
    factor = 1.0
    zeros = np.zeros(n)
    for s in range(steps):
        t = s / control_hz
        if drift is not None and s % drift_every == 0:
            factor = drift.apply(sim, base, t)
        _core.compensator_sense(comp.model, comp.data, block.encoders(data))
        q_ref, qd_ref = q_ref_all[s], qd_ref_all[s]
        tau = kp * (q_ref - np.array(comp.data.q)) + kd * (qd_ref - np.array(comp.data.qd))
        _core.compensator_command(comp.model, comp.data, tau)
        block.run(data, np.array(comp.data.torque_motor), zeros)
        if s % every == 0:
            times.append(t)
            truth.append(factor)
            sc.append(np.array(comp.data.tracking.scale_constant))
            sv.append(np.array(comp.data.tracking.scale_viscous))
    return TrackingRun(compiled.name, np.array(times), np.array(truth), np.array(sc), np.array(sv),
                       np.array(comp.data.tracking.updates))
