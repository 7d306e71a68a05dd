"""S0 Fig. 7 on the twin (C11), passivity and a stiff virtual wall, with the real-time compensator (C10, C46).

A simulated hand — a spring–damper pulling the handle along a horizontal circle — moves the end effector of
the L-EXOS twin in free space, first with gravity compensation only (k = 0: the motors give the lossless static
torques of g(q), as in S0 §IV-C), then with friction compensation added (k = ``underestimation``). The twin
runs in torque mode at ``rate_hz`` with the compensator (``tendyn._core.compensator_cycle``) computing the motor
torques every control period from the simulated, quantised encoder readings; the hand enters as the external
joint torque Jᵀ F_hand (Pinocchio frame Jacobian of the handle, an independent route from the core chain).

Reported: the RMS joint-1 torque the hand needs in both cases and its reduction (C11 claims > 50 %), the work
the device does on the hand per closed cycle (≤ 0: no net energy injected), and for a stiff virtual wall
(:class:`tendyn.control.Renderer`, K_st) whether the contact settles or keeps a limit cycle; the same for an
over-compensating k > 1.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from tendyn import _core
from tendyn.control import Compensator, Renderer
from tendyn.control.compensator import (DEFAULT_UNDERESTIMATION, DEFAULT_VELOCITY_BAND,
                                        DEFAULT_VELOCITY_CUTOFF_HZ)
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.results import Result, format_table
from tendyn.pipelines.twin_loop import ControlBlock as _Block, reset_at as _reset
from tendyn.sim.model import sim_model

__all__ = ["Fig7Result", "HandRun", "HandTask", "WallRun", "fig7_experiment", "hand_run", "hand_task", "wall_run",
           "compensation_summary"]

HAND_RADIUS = 0.04
"""Radius of the hand's circle [m] (S0 Fig. 7's few-centimetre circle), at most 15 % of the handle's distance from
the base so that it stays in a small device's workspace."""


@dataclass(frozen=True)
class HandTask:
    """Where the hand and wall experiments happen on a device, derived from the device alone.

    q0 : start pose [rad] (the device file's ``home_pose``, else the pose of best handle mobility on a grid of the
        joint ranges); u, v : orthonormal directions of the circle's plane (base frame) [-]; radius [m];
        wall_normal : unit normal of the virtual floor, pointing from the wall to the handle [-]
    """

    q0: np.ndarray
    u: np.ndarray
    v: np.ndarray
    radius: float
    wall_normal: np.ndarray


def _unit(x) -> np.ndarray:
    x = np.asarray(x, float)
    return x / np.linalg.norm(x)


_HAND_TASKS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # per compiled device: a grid search each


def hand_task(device) -> HandTask:
    """The hand task of any serial cable device (:class:`HandTask`).

    Circle plane: horizontal (⊥ gravity) where the handle moves as freely in it as in its best plane (the smaller
    singular value of the Jacobian restricted to it at least half that of the Jacobian), with u along the base x
    axis made horizontal; else the plane of the two leading left singular vectors of the handle Jacobian at q0
    (a planar device moves in its plane whatever gravity does). Wall: a floor (normal −ĝ) where the handle moves
    vertically, else normal to the direction the handle moves most easily."""
    compiled = _device(device)
    if compiled not in _HAND_TASKS:   # every hand and wall run of a figure asks again
        _HAND_TASKS[compiled] = _hand_task(compiled)
    return _HAND_TASKS[compiled]


def _hand_task(compiled) -> HandTask:
    dev = compiled.device
    handle = _Handle(compiled)
    lo, hi, tree_lo, tree_hi, L, c = _active_limits(compiled)
    if dev.home_pose is not None:
        q0 = np.array(dev.home_pose, float)
    else:
        margin = 0.1 * (hi - lo)
        levels = [np.linspace(a + m, b - m, 3) for a, b, m in zip(lo, hi, margin)]
        n = lo.size
        if 3 ** n <= 729:
            grid = np.stack([g.ravel() for g in np.meshgrid(*levels, indexing="ij")], axis=1)
        else:
            rng = np.random.default_rng(0)
            grid = np.column_stack([rng.choice(lv, 729) for lv in levels])
        qt = grid @ L.T + c        # a closed-loop tree: keep the poses whose passive joints are inside too
        tm = 0.05 * (tree_hi - tree_lo)
        inside = np.all((qt >= tree_lo + tm) & (qt <= tree_hi - tm), axis=1)
        grid = grid[inside] if inside.any() else grid
        k = min(2, n)
        score = [np.linalg.svd(handle(q)[1], compute_uv=False)[k - 1] for q in grid]
        q0 = grid[int(np.argmax(score))]
    x0, J = handle(q0)
    U, S, _ = np.linalg.svd(J)
    g = np.asarray(dev.kinematics.gravity, float)
    u, v = U[:, 0], U[:, 1] * (1.0 if S.size > 1 and S[1] > 1e-9 * S[0] else 0.0)
    normal = U[:, 0]
    if np.linalg.norm(g) > 0:
        gh = _unit(g)
        ex = np.array([1.0, 0.0, 0.0]) - gh[0] * gh
        hu = _unit(ex if np.linalg.norm(ex) > 1e-6 else np.array([0.0, 1.0, 0.0]) - gh[1] * gh)
        hv = np.cross(gh, hu) * -1.0
        Sh = np.linalg.svd(np.vstack([hu, hv]) @ J, compute_uv=False)
        if S.size > 1 and Sh[-1] >= 0.5 * S[1]:
            u, v = hu, hv
        if np.linalg.norm(gh @ J) >= 0.3 * S[0]:
            normal = -gh
    radius = min(HAND_RADIUS, 0.15 * float(np.linalg.norm(x0)))
    return HandTask(q0, u, v, radius, normal)


def _active_limits(compiled):
    """(lower, upper) of the actuated joints [rad], then (lower, upper, L, c) of every tree joint with
    q_tree = L q_a + c (:func:`tendyn.sim.experiments.tree_limits`): a serial chain has L = I."""
    from tendyn.sim.experiments import tree_limits

    tlo, thi, L, c = tree_limits(compiled)
    lo, hi = np.full(L.shape[1], -np.inf), np.full(L.shape[1], np.inf)
    for k in range(L.shape[0]):      # the rows of L that are one actuated joint alone give its limits
        nz = np.flatnonzero(np.abs(L[k]) > 1e-12)
        if nz.size == 1 and abs(L[k, nz[0]] - 1.0) < 1e-12:
            lo[nz[0]] = max(lo[nz[0]], tlo[k] - c[k])
            hi[nz[0]] = min(hi[nz[0]], thi[k] - c[k])
    return lo, hi, tlo, thi, L, c


def _device(device):
    if isinstance(device, str):
        return compile_device(load_device(bundled(device) if "/" not in device and not device.endswith(".toml")
                                          else device))
    return compile_device(device)


class _Handle:
    """Position and linear Jacobian of the end effector from Pinocchio (a frame added to a copy of the model), at
    the actuated joints: q_tree = L q + c and J L on a closed-loop tree (an independent route from the core
    chain's active map)."""

    def __init__(self, compiled):
        import pinocchio as pin

        from tendyn.control.compensator import end_effector_point

        self.pin = pin
        joint, point = end_effector_point(compiled)
        self.model = pin.Model(compiled.pinocchio_model)
        self.frame = self.model.addFrame(pin.Frame("handle", joint + 1, 0, pin.SE3(np.eye(3), point),
                                                   pin.FrameType.OP_FRAME))
        self.data = self.model.createData()
        L, c = compiled.active_map
        self.L, self.c = np.asarray(L, float), np.asarray(c, float)

    def __call__(self, q):
        pin = self.pin
        q_tree = self.L @ np.asarray(q, float) + self.c
        pin.computeJointJacobians(self.model, self.data, q_tree)
        pin.updateFramePlacements(self.model, self.data)
        x = np.array(self.data.oMf[self.frame].translation)
        J = pin.getFrameJacobian(self.model, self.data, self.frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return x, np.asarray(J).reshape(6, -1)[:3] @ self.L   # a 1-joint Jacobian comes back as a vector


@dataclass(eq=False)
class HandRun:
    """One free-motion run: the hand's torques and the energy it exchanges with the device.

    Attributes
    ----------
    underestimation : k [-] of the compensator (0 = gravity compensation only)
    time : (steps,) [s]
    torque_hand : (steps, n) joint torques the hand applies, Jᵀ F_hand [N·m]
    force_hand : (steps, 3) [N]
    rms_joint1 : RMS of torque_hand[:, 0] over the whole cycles measured [N·m]
    energy_to_hand_per_cycle : work the device does on the hand per closed cycle [J] (< 0: the hand works)
    cycles : number of closed cycles measured
    compute_time_mean : mean compensator cycle time inside the loop [s]
    energy_to_hand : (steps,) work the device has done on the hand since the start [J], after each period
    settle : blend-in time before the measured cycles [s]
    """

    underestimation: float
    time: np.ndarray
    torque_hand: np.ndarray
    force_hand: np.ndarray
    rms_joint1: float
    energy_to_hand_per_cycle: float
    cycles: int
    compute_time_mean: float
    energy_to_hand: np.ndarray = field(default_factory=lambda: np.zeros(0))
    settle: float = 0.0

    def energy_windows(self, window: float) -> np.ndarray:
        """Work done on the hand over consecutive windows of ``window`` seconds from the end of the blend-in
        [J]; > 0 in a window means the device gave the hand net energy in it."""
        end_of_period = self.time + (self.time[1] - self.time[0])
        return windowed_energy(end_of_period, self.energy_to_hand, window, self.settle)


def windowed_energy(time: np.ndarray, energy: np.ndarray, window: float, start: float = 0.0) -> np.ndarray:
    """Increments of a cumulative energy [J] sampled at ``time`` [s] over consecutive windows [s] from start."""
    edges = np.arange(start, time[-1] + 1e-12, window)
    values = np.interp(edges, time, energy)
    return np.diff(values)


def hand_run(device="lexos", underestimation: float = 0.0, *, friction=None, radius: float | None = None,
             period: float = 4.0, cycles: int = 1, settle: float = 0.5, hand_stiffness: float = 400.0,
             hand_damping: float = 10.0, rate_hz: float = 10_000.0, control_hz: float = 1_000.0,
             q0=None, seed: int = 7, encoders: str = "quantised", velocity_band: float = DEFAULT_VELOCITY_BAND,
             velocity_cutoff_hz: float = DEFAULT_VELOCITY_CUTOFF_HZ, passivity=None, compensator=None,
             twin_friction_scale: float = 1.0) -> HandRun:
    """The hand pulls the handle around a circle (radius [m], period [s]) in the plane of :func:`hand_task` for
    ``settle`` seconds of blend-in plus ``cycles`` closed cycles, with the compensator at ``underestimation`` k.
    ``q0`` [rad] and ``radius`` default to the hand task's.

    The circle starts at the handle's start position; its radius grows smoothly over ``settle`` so the hand
    does not jerk. RMS and energy are taken over the ``cycles`` closed cycles after ``settle``.
    ``encoders``: ``"quantised"`` (the twin's motor encoders, S0's position sensors) or ``"exact"`` (the motor
    positions themselves, an ideal sensor, C12); ``velocity_band`` [rad/s] and ``velocity_cutoff_hz`` [Hz] are
    the compensator's (:meth:`tendyn.control.Compensator.from_device`), so is ``passivity`` (None: off).
    ``compensator``: use this :class:`tendyn.control.Compensator` (its state kept, its tracker gated off: the
    hand is an unknown force) instead of building one; ``twin_friction_scale`` multiplies the twin's τ_0 and ν
    (:func:`tendyn.pipelines.tracking.scale_twin_friction`), the compensator keeps its model.
    """
    if encoders not in ("quantised", "exact"):
        raise ValueError(f"encoders must be 'quantised' or 'exact' (got {encoders!r})")
    compiled = _device(device)
    task = hand_task(compiled)
    radius = task.radius if radius is None else radius
    sim = sim_model(compiled, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    data = _core.SimData(sim)
    q0 = task.q0 if q0 is None else np.asarray(q0, float)
    if twin_friction_scale != 1.0:
        from tendyn.pipelines.tracking import scale_twin_friction

        scale_twin_friction(sim, compiled.transmission, twin_friction_scale)
    _reset(sim, data, q0, seed)
    if compensator is None:
        comp = Compensator.from_device(compiled, friction=friction, underestimation=underestimation,
                                       rate_hz=control_hz, velocity_band=velocity_band,
                                       velocity_cutoff_hz=velocity_cutoff_hz, passivity=passivity)
    else:
        comp = compensator
        if comp.model.rate_hz != control_hz:
            raise ValueError(f"the compensator runs at {comp.model.rate_hz:g} Hz, the hand at {control_hz:g} Hz")
        comp.data.restart()                      # a new motion: velocity history gone, tracked friction kept
        comp.data.tracking_active = False
    handle = _Handle(compiled)
    x0, _ = handle(q0)
    omega = 2 * np.pi / period
    periods = int(round((settle + cycles * period) * control_hz))
    block = _Block(sim)
    read = block.encoders if encoders == "quantised" else (lambda data_: np.array(data_.q_motor))
    time = np.arange(periods) / control_hz
    torque_hand = np.empty((periods, sim.na))
    force_hand = np.empty((periods, 3))
    ctime = np.empty(periods)
    to_hand = np.empty(periods)
    work_at_settle = 0.0
    for s, t in enumerate(time):
        if abs(t - settle) < 0.5 / control_hz:
            work_at_settle = data.work_external
        torque_motor = comp.cycle(read(data))
        ctime[s] = comp.data.compute_time
        # blended circle: the radius grows with a smooth step over `settle`
        u = min(1.0, t / settle) if settle > 0 else 1.0
        a = 3 * u * u - 2 * u ** 3
        da = (6 * u - 6 * u * u) / settle if settle > 0 and u < 1 else 0.0
        c, sn = np.cos(omega * t), np.sin(omega * t)
        path = x0 + radius * a * ((c - 1.0) * task.u + sn * task.v)
        path_v = radius * a * omega * (-sn * task.u + c * task.v) + radius * da * ((c - 1.0) * task.u + sn * task.v)
        x, J = handle(np.array(data.q))
        f = hand_stiffness * (path - x) + hand_damping * (path_v - J @ np.array(data.qd))
        tau = J.T @ f
        block.run(data, torque_motor, tau)      # one control period, the hand held (1 kHz) like the motors
        torque_hand[s] = tau
        force_hand[s] = f
        to_hand[s] = -data.work_external
    measured = time >= settle - 0.5 / control_hz
    rms = float(np.sqrt(np.mean(torque_hand[measured, 0] ** 2)))
    energy = -(data.work_external - work_at_settle) / cycles   # work done on the hand [J per cycle]
    return HandRun(float(comp.model.underestimation), time, torque_hand, force_hand, rms, float(energy),
                   int(cycles), float(np.mean(ctime)), to_hand, float(settle))


@dataclass(eq=False)
class WallRun:
    """The hand presses the handle into a stiff virtual floor rendered through the compensator.

    Attributes
    ----------
    underestimation : k [-]
    stiffness : K_st [N/m]
    time : (steps,) [s]; height : (steps,) handle height relative to the wall [m] (< 0 inside)
    force : (control periods, 3) rendered F_d [N]
    oscillation : peak-to-peak height over the last ``window`` seconds [m]
    limit_cycle : True when the oscillation stays above ``tolerance``
    energy_to_hand : (steps,) work the device has done on the hand since the start [J], after each period
    """

    underestimation: float
    stiffness: float
    time: np.ndarray
    height: np.ndarray
    force: np.ndarray
    oscillation: float
    limit_cycle: bool
    energy_to_hand: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def energy_windows(self, window: float, start: float = 0.0) -> np.ndarray:
        """Work done on the hand over consecutive windows of ``window`` seconds from ``start`` [s] [J]."""
        end_of_period = self.time + (self.time[1] - self.time[0])
        return windowed_energy(end_of_period, self.energy_to_hand, window, start)


def wall_run(device="lexos", underestimation: float = DEFAULT_UNDERESTIMATION, *, friction=None,
             stiffness: float = 3000.0, damping: float = 0.0, push: float = 0.02, duration: float = 1.5,
             window: float = 0.5, tolerance: float = 2e-4, hand_stiffness: float = 400.0, hand_damping: float = 2.0,
             rate_hz: float = 10_000.0, control_hz: float = 1_000.0, q0=None, seed: int = 7,
             passivity=None) -> WallRun:
    """A wall 5 mm from the handle, across the hand task's wall normal (a floor where the handle moves
    vertically); the hand's target is ``push`` [m] inside it (it presses with about ``hand_stiffness · push``
    newtons). Peak-to-peak height over the last ``window`` seconds tells whether the contact settled (passive) or
    keeps a limit cycle. ``friction``: the identified losses the compensator uses (as :func:`hand_run`);
    ``passivity``: the compensator's passivity controller (:meth:`tendyn.control.Compensator.from_device`)."""
    compiled = _device(device)
    task = hand_task(compiled)
    sim = sim_model(compiled, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    data = _core.SimData(sim)
    q0 = task.q0 if q0 is None else np.asarray(q0, float)
    _reset(sim, data, q0, seed)
    comp = Compensator.from_device(compiled, friction=friction, underestimation=underestimation, rate_hz=control_hz,
                                   passivity=passivity)
    handle = _Handle(compiled)
    x0, _ = handle(q0)
    normal = task.wall_normal
    floor = float(normal @ x0) - 0.005
    rend = Renderer(comp, stiffness=stiffness, damping=damping).add_plane(normal, floor)
    periods = int(round(duration * control_hz))
    target = x0 - normal * (0.005 + push)
    time, height, forces = np.arange(periods) / control_hz, np.empty(periods), np.empty((periods, 3))
    to_hand = np.empty(periods)
    block = _Block(sim)
    for s, t in enumerate(time):
        torque_motor = rend.cycle(block.encoders(data))
        forces[s] = np.array(rend.data.force)
        x, J = handle(np.array(data.q))
        u = min(1.0, t / 0.3)  # the hand presses in over 0.3 s
        goal = x0 + u * (target - x0)
        f = hand_stiffness * (goal - x) - hand_damping * (J @ np.array(data.qd))
        block.run(data, torque_motor, J.T @ f)
        height[s] = float(normal @ x) - floor
        to_hand[s] = -data.work_external
    last = time >= duration - window
    osc = float(np.ptp(height[last]))
    return WallRun(float(underestimation), float(stiffness), time, height, forces, osc, bool(osc > tolerance),
                   to_hand)


@dataclass(eq=False)
class Fig7Result(Result):
    """S0 Fig. 7 on the twin: hand torque at joint 1 with gravity compensation only and with friction
    compensation, passivity per cycle, the wall, and over-compensation.

    Attributes
    ----------
    gravity_only, compensated : HandRun (k = 0 and k = ``underestimation``)
    over : list of HandRun with k > 1
    walls : list of WallRun (k = ``underestimation`` and the over-compensating ones)
    device : name
    """

    gravity_only: HandRun
    compensated: HandRun
    over: list = field(default_factory=list)
    walls: list = field(default_factory=list)
    device: str = "L-EXOS"
    _figsize = (7.0, 4.2)

    @property
    def reduction_joint1(self) -> float:
        """1 − RMS(compensated) / RMS(gravity only) [-] (C11: > 0.5)."""
        return 1.0 - self.compensated.rms_joint1 / self.gravity_only.rms_joint1

    reading = ('The joint-1 torque the hand applies in free motion over time, with gravity compensation only and '
               'with friction compensation too (S0 Fig. 7): the smaller the curve, the lighter the device feels.')

    def _draw(self, ax) -> None:
        for run, color, label in ((self.gravity_only, "tab:red", "gravity compensation only"),
                                  (self.compensated, "tab:blue",
                                   f"gravity + friction compensation (k = {self.compensated.underestimation:g})")):
            ax.plot(run.time, run.torque_hand[:, 0], color=color, lw=1.0, label=label)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("joint-1 torque applied by the hand [N·m]")
        ax.set_title(f"{self.device}: torque to move the end effector in free motion "
                     f"(reduction {100 * self.reduction_joint1:.0f} %)")
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.legend(loc="upper right", fontsize=8)

    def to_dict(self) -> dict:
        comp = self.compensated
        out = {
            "device": self.device,
            "underestimation": comp.underestimation,
            "reduction_joint1": float(self.reduction_joint1),
            "rms_joint1_gravity_only": self.gravity_only.rms_joint1,
            "rms_joint1_compensated": comp.rms_joint1,
            "energy_to_hand_per_cycle": comp.energy_to_hand_per_cycle,
            "energy_to_hand_per_cycle_gravity_only": self.gravity_only.energy_to_hand_per_cycle,
            "cycles": comp.cycles,
            "compute_time_mean_s": comp.compute_time_mean,
            "over_compensation": [
                {"underestimation": r.underestimation, "rms_joint1": r.rms_joint1,
                 "reduction_joint1": float(1.0 - r.rms_joint1 / self.gravity_only.rms_joint1),
                 "energy_to_hand_per_cycle": r.energy_to_hand_per_cycle} for r in self.over],
            "wall": [{"underestimation": w.underestimation, "stiffness": w.stiffness,
                      "oscillation_m": w.oscillation, "limit_cycle": w.limit_cycle} for w in self.walls],
        }
        return out

    def table(self) -> str:
        rows = [("gravity only", 0.0, self.gravity_only.rms_joint1, 0.0, self.gravity_only.energy_to_hand_per_cycle)]
        for r in [self.compensated] + list(self.over):
            rows.append(("gravity + friction", r.underestimation, r.rms_joint1,
                         100 * (1 - r.rms_joint1 / self.gravity_only.rms_joint1), r.energy_to_hand_per_cycle))
        text = format_table(("compensation", "k", "RMS joint-1 [N·m]", "reduction [%]", "energy to hand [J/cycle]"),
                            rows, title=f"S0 Fig. 7 on the {self.device} twin (C11: reduction > 50 %)")
        if self.walls:
            text += "\n\n" + format_table(
                ("k", "K_st [N/m]", "peak-to-peak [mm]", "limit cycle"),
                [(w.underestimation, w.stiffness, 1e3 * w.oscillation, "yes" if w.limit_cycle else "no")
                 for w in self.walls], title="stiff virtual wall, hand pressing in")
        return text


def fig7_experiment(device="lexos", *, underestimation: float = DEFAULT_UNDERESTIMATION, friction=None,
                    over=(1.2, 1.5), walls: bool = True, cycles: int = 1, seed: int = 7, **hand) -> Fig7Result:
    """Run S0 Fig. 7 on the twin (gravity only, then k = ``underestimation``), the over-compensating k in
    ``over``, and (``walls``) the stiff wall at k = ``underestimation`` and at each over-compensating k.

    ``friction`` (None, mapping or FRICTION.json path) are the identified losses the compensator uses; the twin
    always keeps its own (true) losses. ``device`` may be a calibrated device
    (:func:`tendyn.ident.calibrated.calibrate`): its one loss model, built once, is every run's. ``hand`` passes the
    path and hand options to :func:`hand_run`.
    """
    from tendyn.ident.calibrated import unwrap

    device, friction = unwrap(device, friction)       # a calibrated device: its compiled device and loss model
    compiled = _device(device)
    g = hand_run(compiled, 0.0, cycles=cycles, seed=seed, **hand)
    c = hand_run(compiled, underestimation, friction=friction, cycles=cycles, seed=seed, **hand)
    o = [hand_run(compiled, k, friction=friction, cycles=cycles, seed=seed, **hand) for k in over]
    w = [wall_run(compiled, k, friction=friction, seed=seed) for k in ((underestimation,) + tuple(over))] if walls else []
    return Fig7Result(g, c, o, w, device=compiled.name)


def compensation_summary(result: Fig7Result) -> dict:
    """The ``compensation`` part of ``tendyn pipeline s0 --json``."""
    return result.to_dict()
