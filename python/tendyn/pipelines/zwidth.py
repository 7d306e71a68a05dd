"""Z-width of the rendered virtual wall (Colgate & Brown): the stiffness K and damping B a device renders stably
at its control rate, found on its twin, with and without compensation and with the passivity controller.

One grid point (:func:`zwidth_point`): the twin of a serial cable-driven device (torque mode, its own losses,
quantised motor encoders) starts at rest at the device's hand-task pose with the handle ``gap`` from a wall across
the hand task's wall normal (:func:`tendyn.pipelines.s0_compensation.hand_task`: a floor where the handle moves
vertically), rendered through the compensator (:class:`tendyn.control.Renderer`, ``K_st = K``, ``K_d = B``); a
constant hand force ``push`` [N] presses the handle in (a conservative load: any energy growth comes from the
device and its controller). The twin runs ``horizon`` seconds.

Stability criterion (stated once, here, and tested): split the run after the impact into the middle and the
last third of the horizon; the wall is **unstable** when the handle height still oscillates in the last third
(peak-to-peak above ``tolerance``, a limit cycle) or the oscillation grows from the middle to the last third
(``growth`` > 1 with a peak-to-peak above ``tolerance / 10``: energy growth). Otherwise stable.

Compared with the sampled-data passivity bound of Colgate & Schenkel, b > K T / 2 + |B| (b the device's
physical viscous damping along the wall normal, T the control period): the passive region K < 2 (b − |B|) / T.
b is the device's viscous friction reflected to the handle along the normal, less what the mode's compensator
gives back of it (:func:`colgate_damping`); Coulomb friction is not in Colgate's b, so the twin's stable region
is larger than the bound's.

The grid runs on Dask (a local cluster by default, ``scheduler`` for a real one), like ``tendyn sweep``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from tendyn.results import Result, format_table

__all__ = ["MODES", "ZWidthResult", "zwidth_point", "is_stable", "run_zwidth", "colgate_damping",
           "reflected_damping", "max_push", "default_push", "DEFAULT_STIFFNESS", "DEFAULT_DAMPING", "DEFAULT_PUSH"]

MODES = ("gravity", "compensated", "passivity")
"""gravity: k = 0 (gravity compensation only); compensated: the compensator as given, controller off;
passivity: the same with the passivity observer and controller on."""
DEFAULT_STIFFNESS = (1000.0, 1.0e6, 13)
"""K grid [N/m]: low, high, points (log-spaced)."""
DEFAULT_DAMPING = (0.0, 60.0, 7)
"""B grid [N·s/m]: low, high, points."""


def is_stable(height: np.ndarray, tolerance: float) -> tuple[bool, float, float]:
    """The criterion of the module docstring on a height trace [m] sampled uniformly over the horizon:
    (stable, peak-to-peak of the last third [m], growth = last / middle peak-to-peak [-])."""
    n = len(height)
    mid, last = height[n // 3: 2 * n // 3], height[2 * n // 3:]
    p_mid, p_last = float(np.ptp(mid)), float(np.ptp(last))
    growth = p_last / p_mid if p_mid > 0 else (np.inf if p_last > 0 else 1.0)
    unstable = p_last > tolerance or (growth > 1.0 and p_last > tolerance / 10)
    return not unstable, p_last, float(growth)


def _task(compiled, q0=None, normal=None) -> tuple[np.ndarray, np.ndarray]:
    """Start pose [rad] and wall normal (unit, base frame) of the hand task, unless given."""
    if q0 is None or normal is None:
        from tendyn.pipelines.s0_compensation import hand_task

        task = hand_task(compiled)
        q0 = task.q0 if q0 is None else q0
        normal = task.wall_normal if normal is None else normal
    return np.asarray(q0, float), np.asarray(normal, float)


def zwidth_point(device: Any, stiffness: float, damping: float, *, compensator_text: str | None = None,
                 mode: str = "compensated", push: float = 10.0, gap: float = 0.001, horizon: float = 0.6,
                 tolerance: float = 1e-4, rate_hz: float = 10_000.0, control_hz: float | None = None,
                 q0=None, normal=None, seed: int = 7) -> dict:
    """One (K [N/m], B [N·s/m]) point on the twin; plain in, plain out (a Dask task).

    ``compensator_text`` is a compensator model file's text (None: :meth:`Compensator.from_device` defaults);
    ``mode`` one of :data:`MODES`; ``q0`` [rad] and the wall ``normal`` default to the hand task's. Returns K, B,
    mode, stable, oscillation [m] (last third), growth [-], penetration [m] (mean depth in the last third),
    energy_to_hand_last [J] (work on the hand in the last third).
    """
    from tendyn import _core
    from tendyn.control import Compensator, Renderer, passivity_model
    from tendyn.device import compile_device
    from tendyn.pipelines.twin_loop import ControlBlock, reset_at
    from tendyn.sim.model import sim_model

    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)} (got {mode!r})")
    compiled = compile_device(device)
    if compensator_text is None:
        comp = Compensator.from_device(compiled, rate_hz=control_hz or 1000.0)
    else:
        comp = Compensator(_core.parse_compensator_model(compensator_text, "compensator", compiled.name))
    control_hz = comp.model.rate_hz
    if mode == "gravity":
        comp = comp.with_settings(underestimation=0.0, passivity=None)
    elif mode == "compensated":
        comp = comp.with_settings(passivity=None)
    elif not comp.model.passivity.enabled:
        comp = comp.with_settings(passivity=passivity_model(compiled, rate_hz=control_hz))
    sim = sim_model(compiled, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    data = _core.SimData(sim)
    q0, normal = _task(compiled, q0, normal)
    reset_at(sim, data, q0, seed)
    chain = comp.model.chain
    cdata = _core.ChainData(chain)
    _core.chain_active(chain, cdata, q0)
    floor = float(normal @ cdata.ee_position) - gap
    rend = Renderer(comp, stiffness=stiffness, damping=damping).add_plane(normal, floor)
    force = -float(push) * normal
    periods = int(round(horizon * control_hz))
    height, to_hand = np.empty(periods), np.empty(periods)
    block = ControlBlock(sim)
    for s in range(periods):
        torque_motor = rend.cycle(block.encoders(data))
        _core.chain_active(chain, cdata, np.array(data.q))
        block.run(data, torque_motor, np.asarray(cdata.ee_jacobian_active).T @ force)
        height[s] = float(normal @ cdata.ee_position) - floor
        to_hand[s] = -data.work_external
        if not np.isfinite(height[s]) or abs(height[s]) > 1.0:   # thrown off: unstable, stop early
            height[s:] = height[s] if np.isfinite(height[s]) else 1.0
            to_hand[s:] = to_hand[s] if np.isfinite(to_hand[s]) else np.inf
            break
    stable, osc, growth = is_stable(height, tolerance)
    last = slice(2 * periods // 3, None)
    return {"K": float(stiffness), "B": float(damping), "mode": mode, "stable": bool(stable),
            "oscillation": osc, "growth": growth, "penetration": float(-np.mean(height[last])),
            "energy_to_hand_last": float(to_hand[-1] - to_hand[2 * periods // 3])}


DEFAULT_PUSH = 10.0
"""Hand force [N] pressing the handle into the wall, when the device can hold twice that (:func:`default_push`)."""
PUSH_SHARE = 0.5
"""Share of :func:`max_push` the default push takes on a device too weak for :data:`DEFAULT_PUSH`."""


def max_push(device: Any, *, q0=None, normal=None) -> float:
    """The largest hand force [N] along −normal the motors can hold at the wall pose: the wall pushes back with
    F n, so the motors give C = M (J_aᵀ n F + g_a) (M the lossless motor-from-joint torque map, g_a the gravity at
    the actuated joints, chain.hpp); the push saturates the first motor i where |C_i| reaches its peak torque:
    F_max = min_i (peak_i − |M g_a|_i) / |M J_aᵀ n|_i (0 when gravity alone saturates a motor)."""
    from tendyn import _core
    from tendyn.control import chain_model
    from tendyn.control.compensator import device_transmission
    from tendyn.device import compile_device

    compiled = compile_device(device)
    dev = compiled.device
    peak = np.array([a.motor.peak_torque for a in (dev.transmissions or dev.drives)], float)
    Mt = np.array(device_transmission(compiled).model.motor_from_joint_torque)
    chain = chain_model(compiled)
    cdata = _core.ChainData(chain)
    q0, normal = _task(compiled, q0, normal)
    _core.chain_active(chain, cdata, q0)
    per_newton = np.abs(Mt @ (np.asarray(cdata.ee_jacobian_active).T @ normal))
    left = np.maximum(peak - np.abs(Mt @ np.asarray(cdata.gravity_active)), 0.0)
    with np.errstate(divide="ignore"):
        f = np.where(per_newton > 1e-15, left / np.maximum(per_newton, 1e-300), np.inf)
    return float(np.min(f))


def default_push(device: Any, *, q0=None, normal=None) -> tuple[float, str | None]:
    """(push [N], note): :data:`DEFAULT_PUSH` when the motors hold twice that (:func:`max_push`), else
    :data:`PUSH_SHARE` of what they hold, with a one-line note saying why."""
    fmax = max_push(device, q0=q0, normal=normal)
    if fmax >= DEFAULT_PUSH / PUSH_SHARE:
        return DEFAULT_PUSH, None
    push = PUSH_SHARE * fmax
    return push, (f"the default push {DEFAULT_PUSH:g} N is more than the motors hold along the wall normal "
                  f"({fmax:.3g} N at their peak torques): pushing with {push:.3g} N")


def reflected_damping(device: Any, viscous, *, q0=None, normal=None) -> float:
    """Motor viscous damping ``viscous`` (n) [N·m·s/rad] seen at the handle along the wall normal n [N·s/m]: the
    least-damped joint motion that moves the handle at 1 m/s along n, min q̇ᵀ B_q q̇ subject to J_n q̇ = 1
    (J_n = nᵀ J), is 1 / (J_n B_q⁻¹ J_nᵀ), B_q = R⁻ᵀ diag(viscous) R⁻¹ with q̇ = R q̇_m (R the joint-from-motor
    map). ``q0`` and ``normal`` default to the hand task's."""
    from tendyn import _core
    from tendyn.control import chain_model
    from tendyn.control.compensator import device_transmission
    from tendyn.device import compile_device

    compiled = compile_device(device)
    motor_from_joint = np.linalg.inv(np.array(device_transmission(compiled).model.joint_from_motor_position))
    Bq = motor_from_joint.T @ np.diag(np.asarray(viscous, float)) @ motor_from_joint
    chain = chain_model(compiled)
    cdata = _core.ChainData(chain)
    q0, normal = _task(compiled, q0, normal)
    _core.chain_active(chain, cdata, q0)
    jz = normal @ np.asarray(cdata.ee_jacobian_active)
    x = np.linalg.lstsq(Bq + 1e-12 * np.eye(len(jz)), jz, rcond=None)[0]
    return float(1.0 / (jz @ x))


def colgate_damping(device: Any, compensator_text: str | None = None, *, q0=None, normal=None) -> dict:
    """Colgate's b [N·s/m] per mode: the device's viscous friction at the handle along the normal (its own
    losses, :func:`tendyn.control.dissipation_bound` with margin 1, :func:`reflected_damping`), less what each
    mode's compensator returns of it: gravity b; compensated max(0, 1 − k) b; passivity the larger of that and
    the b of the motor viscous friction less the controller's certified viscous bound (the compensator may give
    back at most that bound)."""
    from tendyn import _core
    from tendyn.control import Compensator, dissipation_bound, passivity_model
    from tendyn.device import compile_device

    compiled = compile_device(device)
    _, viscous = dissipation_bound(compiled, margin=1.0)
    q0, normal = _task(compiled, q0, normal)
    b = reflected_damping(compiled, viscous, q0=q0, normal=normal)
    model = (Compensator.from_device(compiled).model if compensator_text is None
             else _core.parse_compensator_model(compensator_text, "compensator", compiled.name))
    k = model.underestimation
    pc = model.passivity if model.passivity.enabled else passivity_model(compiled, rate_hz=model.rate_hz)
    compensated = max(0.0, 1.0 - k) * b
    left = np.maximum(viscous - np.asarray(pc.dissipation_viscous, float), 0.0)   # what the controller leaves
    return {"gravity": b, "compensated": compensated,
            "passivity": max(compensated, reflected_damping(compiled, left, q0=q0, normal=normal))}


@dataclass(eq=False)
class ZWidthResult(Result):
    """The stable (K, B) region per mode, and Colgate's passive region.

    Attributes
    ----------
    device : name; rate_hz : control rate [Hz]; rows : one dict per (mode, K, B) (:func:`zwidth_point`)
    stiffness, damping : the grids [N/m], [N·s/m]; modes : the modes run
    colgate_b : {mode: b} viscous damping along the normal [N·s/m] of the bound b > K T / 2 + |B|
        (:func:`colgate_damping`)
    criterion : the stability criterion in words; scheduler : where the grid ran
    friction_source : the friction the compensator uses: ``file`` (the device file's losses) or ``identified:
        <document>`` (a calibrated device's, or the one a compensator file records)
    """

    device: str
    rate_hz: float
    rows: list
    stiffness: np.ndarray
    damping: np.ndarray
    modes: tuple
    colgate_b: dict
    criterion: str = ""
    scheduler: str = "local"
    friction_source: str = "file"
    _figsize = (4.0, 3.6)

    def stable_fraction(self, mode: str) -> float:
        r = [row["stable"] for row in self.rows if row["mode"] == mode]
        return float(np.mean(r)) if r else float("nan")

    def max_stable_stiffness(self, mode: str, damping: float | None = None) -> float:
        """Largest K [N/m] stable in ``mode`` at the grid damping closest to ``damping`` (default the lowest),
        with every lower K stable too (0 when the lowest is not)."""
        b = self.damping[np.argmin(np.abs(self.damping - (self.damping.min() if damping is None else damping)))]
        rows = sorted((r for r in self.rows if r["mode"] == mode and r["B"] == b), key=lambda r: r["K"])
        best = 0.0
        for r in rows:
            if not r["stable"]:
                break
            best = r["K"]
        return best

    def colgate_max_stiffness(self, mode: str, damping: float = 0.0) -> float:
        """K [N/m] of the passivity bound of ``mode`` at B: 2 (b − |B|) / T (≤ 0: no passive wall)."""
        return 2.0 * (self.colgate_b[mode] - abs(damping)) * self.rate_hz

    def __post_init__(self):
        self._panels = len(self.modes)      # one panel per mode (Result.plot)

    reading = ('Each point is one rendered wall (stiffness K, damping B): green stable, red crosses unstable; the '
               'black line is the Colgate passivity bound, and the stable region is the Z-width of the device.')

    def _draw(self, ax) -> None:
        axes = list(ax) if isinstance(ax, (list, tuple)) else [ax]
        for ax_, mode in zip(axes, self.modes):
            self._draw_mode(ax_, mode)

    def _draw_mode(self, ax, mode: str) -> None:
        rows = [r for r in self.rows if r["mode"] == mode]
        k = np.array([r["K"] for r in rows])
        b = np.array([r["B"] for r in rows])
        ok = np.array([r["stable"] for r in rows], bool)
        ax.scatter(k[ok], b[ok], marker="o", color="tab:green", s=14, label="stable")
        ax.scatter(k[~ok], b[~ok], marker="x", color="tab:red", s=14, label="unstable")
        bb = np.linspace(0.0, self.colgate_b[mode], 200)
        kk = 2.0 * (self.colgate_b[mode] - bb) * self.rate_hz
        keep = kk >= max(self.stiffness.min(), 1e-9) * 0.5
        ax.plot(kk[keep], bb[keep], color="k", lw=1.0,
                label=f"Colgate b > KT/2 + |B|, b = {self.colgate_b[mode]:.3g} N·s/m")
        ax.set_xlabel("wall stiffness K [N/m]")
        ax.set_ylabel("wall damping B [N·s/m]")
        ax.set_title(f"{self.device}, {mode} ({self.rate_hz:g} Hz)", fontsize=9)
        if self.stiffness.min() > 0 and self.stiffness.max() / self.stiffness.min() > 10:
            ax.set_xscale("log")
        ax.legend(fontsize=7, loc="best")

    def to_dict(self) -> dict:
        return {"device": self.device, "rate_hz": self.rate_hz, "criterion": self.criterion,
                "stiffness": [float(x) for x in self.stiffness], "damping": [float(x) for x in self.damping],
                "modes": list(self.modes), "colgate_b": {m: self.colgate_b[m] for m in self.modes},
                "scheduler": self.scheduler, "friction_source": self.friction_source,
                "summary": {m: {"stable_fraction": self.stable_fraction(m),
                                "max_stable_stiffness_at_lowest_damping": self.max_stable_stiffness(m),
                                "colgate_max_stiffness_at_zero_damping": self.colgate_max_stiffness(m)}
                            for m in self.modes},
                "rows": self.rows}

    def table(self) -> str:
        rows = [(m, 100 * self.stable_fraction(m), self.max_stable_stiffness(m), self.colgate_b[m],
                 max(0.0, self.colgate_max_stiffness(m))) for m in self.modes]
        text = format_table(("mode", "stable points [%]", f"max stable K at B = {self.damping.min():g} [N/m]",
                             "Colgate b [N·s/m]", "Colgate K at B = 0 [N/m]"),
                            rows, title=f"{self.device}: Z-width at {self.rate_hz:g} Hz")
        return text + f"\ncriterion: {self.criterion}\ncompensated friction: {self.friction_source}"


CRITERION = ("unstable when the handle height oscillates by more than the tolerance (peak-to-peak) in the last "
             "third of the horizon, or the oscillation grows from the middle to the last third")


def run_zwidth(device: Any, *, stiffness: Sequence[float] | None = None, damping: Sequence[float] | None = None,
               modes: Sequence[str] = MODES, compensator_text: str | None = None, scheduler: str | None = None,
               n_workers: int = 2, progress: bool = True, client=None, **point) -> ZWidthResult:
    """Every (mode, K, B) point on Dask: ``scheduler`` an address or None (a local cluster of ``n_workers``,
    :func:`tendyn.pipelines.sweep.local_cluster`), ``client`` an existing Client, ``scheduler="none"`` in
    process. ``point`` passes options to :func:`zwidth_point`.

    ``device`` may be a calibrated device (:func:`tendyn.ident.calibrated.calibrate`): with identified friction the
    compensator of every mode is built once from its one loss model (the passivity bound too) and handed to the
    points as a model file's text; the twin keeps the device file's losses (the plant the compensator meets)."""
    from tendyn.device import compile_device
    from tendyn.ident.calibrated import CalibratedDevice

    friction_source = "file"
    if isinstance(device, CalibratedDevice):
        if device.friction_source() != "file":
            if compensator_text is not None:
                raise ValueError("give identified friction or a compensator model file, not both")
            from tendyn.control import Compensator

            compensator_text = Compensator.from_device(device, passivity=True,
                                                       rate_hz=point.get("control_hz") or 1000.0).text()
            friction_source = device.friction_source()
        device = device.compiled
    elif compensator_text is not None:
        from tendyn import _core

        recorded = _core.parse_compensator_model(compensator_text, "compensator", "").friction_source
        friction_source = f"identified: {recorded}" if recorded else "file"
    compiled = compile_device(device)
    if compiled.kind != "serial" or not (compiled.device.transmissions or compiled.device.drives):
        raise ValueError(f"{compiled.name}: Z-width needs a serial device with cable transmissions or capstan drives")
    for m in modes:
        if m not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)} (got {m!r})")
    ks = np.linspace(*DEFAULT_STIFFNESS[:2], DEFAULT_STIFFNESS[2]) if stiffness is None else np.asarray(stiffness, float)
    bs = np.linspace(*DEFAULT_DAMPING[:2], DEFAULT_DAMPING[2]) if damping is None else np.asarray(damping, float)
    tasks = [(m, float(k), float(b)) for m in modes for k in ks for b in bs]
    dev = compiled.device
    point["q0"], point["normal"] = _task(compiled, point.get("q0"), point.get("normal"))
    if scheduler == "none":
        rows = [zwidth_point(dev, k, b, mode=m, compensator_text=compensator_text, **point) for m, k, b in tasks]
        where = "in process"
    else:
        rows, where = _on_dask(dev, tasks, compensator_text, point, scheduler, n_workers, progress, client)
    return ZWidthResult(compiled.name, _rate(compiled, compensator_text, point), rows, ks, bs, tuple(modes),
                        colgate_damping(compiled, compensator_text, q0=point["q0"], normal=point["normal"]),
                        CRITERION, where, friction_source)


def _rate(compiled, compensator_text, point) -> float:
    from tendyn import _core

    if compensator_text is not None:
        return float(_core.parse_compensator_model(compensator_text, "compensator", compiled.name).rate_hz)
    return float(point.get("control_hz") or 1000.0)


def _on_dask(dev, tasks, compensator_text, point, scheduler, n_workers, progress, client):
    from tendyn.pipelines.sweep import dask_client, gather_in_order

    with dask_client(scheduler, n_workers, client) as client:
        futures = [client.submit(zwidth_point, dev, k, b, mode=m, compensator_text=compensator_text, pure=False,
                                 **point) for m, k, b in tasks]
        rows = gather_in_order(futures, f"{dev.name}: Z-width", "point", progress)
    return rows, scheduler or f"local ({n_workers} workers)"
