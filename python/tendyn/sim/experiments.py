"""Experiments run on a twin: each builds references, runs the C++ loop and returns a log.

The log (tendyn.io.logs) holds only what a real bench would record: motor encoders, measured motor
torques (current × k_t with noise), commands and references. The twin's parameters and true states
go beside it (``SimRun.truth``), never inside what an estimator reads.

Every experiment takes a Device or its :func:`tendyn.device.compile_device` form and compiles it at entry,
so the rigid-body model, the active-coordinate map and the transmission are built once per device (not
once per run, nor again for the PID gains). Names: joint velocity ``qd``, motor velocity ``qd_motor``,
frequency grids ``omega`` [rad/s], single frequencies ``*_hz`` (docs/naming.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import math

import numpy as np
import pinocchio as pin

from tendyn import _core
from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.device.rigid_body import standard_parameters
from tendyn.device.schema import TRANSMISSION_MODEL_FIELDS
from tendyn.errors import UsageError
from tendyn.io import to_jsonable
from tendyn.io.logs import Log, make_log
from tendyn.protocols import LOOP_BANDWIDTH_HZ, ConstantVelocityTest, references as cv_references
from tendyn.protocols import check_index as _check_index
from tendyn.protocols import (constant_velocity_duration, constant_velocity_profile,  # noqa: F401 (API)
                               constant_velocity_references)
from tendyn.results import FrequencyResponse
from tendyn.sim.model import run_log, sim_model


@dataclass
class SimRun:
    """One simulated experiment: the log an estimator may read, and the truth it may not."""

    log: Log
    truth: dict = field(default_factory=dict)       # parameters of the twin (JSON-able)
    states: dict = field(default_factory=dict)      # true joint/motor trajectories at the log rate


def device_truth(device) -> dict:
    """The twin's parameters that identification tries to recover (JSON-able)."""
    out = {"device": device.name}
    if getattr(device, "n_plus_one", False):
        from tendyn.device.routing_checks import routing_matrix

        tr = device.transmissions
        out["tendons"] = {"K": routing_matrix(tr, device.n_joints),
                          "motor_radius": [t.motor_radius for t in tr], "pretension": [t.pretension for t in tr],
                          "tau0": [[f.tau0 for f in t.friction] for t in tr],
                          "nu": [[f.nu for f in t.friction] for t in tr]}
    elif device.transmissions:
        arr = device.routing_arrays()
        out["routing"] = {f.name: arr[f.name] for f in TRANSMISSION_MODEL_FIELDS}
    drives = getattr(device, "drives", ())
    if drives:
        out["drives"] = [{k: getattr(d, k) for k in ("joint", "ratio", "stiffness_motor", "damping_motor",
                                                    "coulomb_motor", "viscous_motor", "offset_joint")}
                         for d in drives]
    terms = getattr(device, "terms", ())
    if terms:
        out["terms"] = {n: v for t in terms for n, v in zip(t.column_names, t.values or [0.0] * len(t.column_names))}
    return to_jsonable(out)


def pid_gains(m: _core.SimModel, device: Device | CompiledDevice, q0, bandwidth_hz: float = 4.0,
              zeta: float = 0.9, space: str = "joint", integral: bool = True):
    """PID gains that place each axis at ``bandwidth_hz`` with damping ``zeta`` on its own inertia
    (joint-space diagonal of Lᵀ M L + reflected rotors, or motor-space), at configuration q0.

    The mass matrix comes from the compiled device's Pinocchio model (nothing is rebuilt)."""
    compiled = compile_device(device)
    pm = compiled.pinocchio_model
    L, c = np.array(m.L), np.array(m.c)
    Mt = pin.crba(pm, compiled.pinocchio_data(), L @ q0 + c)
    Mt = np.triu(Mt) + np.triu(Mt, 1).T
    Ma = L.T @ Mt @ L
    na = m.na
    if m.drive in (_core.DriveKind.Tendon, _core.DriveKind.Tendons):
        Gm = np.array(m.Gm)                      # (nm, na): R_m⁻¹ K
        Ma = Ma + Gm.T @ np.diag(np.array(m.rotor_inertia)) @ Gm
    else:
        Gm = np.diag(np.array(m.ratio))
        Ma = Ma + Gm.T @ np.diag(np.array(m.rotor_inertia)) @ Gm
    if space == "motor":
        Gi = np.linalg.pinv(Gm)
        Ma = Gi.T @ Ma @ Gi
    inertia = np.diag(Ma)
    w = 2 * np.pi * bandwidth_hz
    kp = inertia * w**2
    kd = 2 * zeta * w * inertia
    ki = kp * w / 10 if integral else np.zeros(na)
    return kp, kd, ki


def run_on_twin(device: Device | CompiledDevice, m: _core.SimModel, q0, ref_q, ref_qd, ff, ext, *, seed: int, experiment: str,
                options: dict, log_rate_hz: float, reference_space: str | None = None,
                progress=None) -> SimRun:
    """Run the loop and assemble the log (+ truth). ``progress(done, total)`` is called between chunks.

    ref_q, ref_qd : (n, na) position [rad] and velocity [rad/s] references (joint or motor space)."""
    device = compile_device(device).device
    rate = 1.0 / m.dt
    log_every = int(round(rate / log_rate_hz))
    if log_every % m.control_decimation:
        raise ValueError("the log rate must divide the control rate")
    d = _core.SimData(m)
    d.reset(np.asarray(q0, float), int(seed))
    if m.drive == _core.DriveKind.Elastic:  # motors start where the springs are relaxed
        d.set_motor_position(np.array(m.ratio) * np.asarray(q0, float))
    ext = np.zeros_like(ref_q) if ext is None else ext
    raw = _run_chunked(m, d, ref_q, ref_qd, ff, ext, log_every, progress)
    if d.stop_contact_time > 0.0:    # the twin met an end stop (sim.hpp): the log says which and for how long
        options = {**options, "end_stops": {"joints": stops_touched(device, raw["q_joint"]),
                                            "contact_s": float(d.stop_contact_time)}}
    cols = {"time": raw["time"]}
    na, nm = m.na, m.nm
    for i in range(nm):
        cols[f"q_motor_{i + 1}"] = raw["q_motor_meas"][:, i]
    for i in range(nm):
        cols[f"torque_motor_{i + 1}"] = raw["torque_motor_meas"][:, i]
    for i in range(nm):
        cols[f"torque_motor_cmd_{i + 1}"] = raw["torque_motor_cmd"][:, i]
    if reference_space is not None:
        prefix = "q_ref_" if reference_space == "joint" else "q_motor_ref_"
        vprefix = "qd_ref_" if reference_space == "joint" else "qd_motor_ref_"
        for i in range(ref_q.shape[1]):
            cols[f"{prefix}{i + 1}"] = ref_q[::log_every, i]
            cols[f"{vprefix}{i + 1}"] = ref_qd[::log_every, i]
    if np.any(ext):
        for i in range(na):
            cols[f"torque_joint_ext_{i + 1}"] = ext[::log_every, i]
    if m.mode != _core.ControlMode.Torque and "controller" not in options:
        # the loop a closed-loop estimator simulates (IDIM-IV, DIDIM: tendyn.ident.closed_loop.LoopController)
        motor = m.mode == _core.ControlMode.MotorPID
        options = {**options, "controller": {
            "kind": "pid", "space": "motor" if motor else "joint", "kp": list(map(float, m.kp)),
            "kd": list(map(float, m.kd)), "ki": list(map(float, m.ki)),
            "velocity_cutoff_hz": float(m.velocity_cutoff_hz), "velocity_feedforward": True,
            "control_hz": float(rate / m.control_decimation), "gain": None,
            "label": f"twin {'motor' if motor else 'joint'}-space PID"}}
    log = make_log(cols, device=device.name, rate_hz=log_rate_hz, seed=int(seed), experiment=experiment,
                   options=to_jsonable(options))
    states = {k: raw[k] for k in ("q_joint", "qd_joint", "q_motor", "qd_motor")}
    return SimRun(log, device_truth(device), states)


def _run_chunked(m, d, ref_q, ref_qd, ff, ext, log_every, progress, chunks: int = 40):
    """run_log over consecutive chunks (same state), so long runs can report progress."""
    n = ref_q.shape[0]
    size = max(log_every, (n // chunks) // log_every * log_every) if progress else n
    parts = []
    for start in range(0, n, size):
        sl = slice(start, min(n, start + size))
        parts.append(run_log(m, d, ref_q[sl], ref_qd[sl], ff[sl], ext[sl], log_every))
        if progress:
            progress(sl.stop, n)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


# ---- reference profiles --------------------------------------------------------------------------

def triangle_wave(t, freq: float, amplitude: float, phase: float = 0.0):
    """Triangle wave starting at 0 and rising, period 1/freq, ± amplitude: returns (value, slope)."""
    x = 2 * np.pi * (freq * t + phase)
    return amplitude * (2 / np.pi) * np.arcsin(np.sin(x)), amplitude * 4 * freq * np.sign(np.cos(x))


def triangle_sine_profile(duration: float, dt: float, amplitude: float, f_tri: float, f_sin, a_sin: float,
                          phase: float = 0.0):
    """Triangular wave (± amplitude) plus a sum of sines (exciting trajectories, S2 §VI): (q, qd)."""
    t = np.arange(int(round(duration / dt))) * dt
    tri, dtri = triangle_wave(t, f_tri, amplitude, phase)
    s = sum(a_sin * np.sin(2 * np.pi * f * t) for f in f_sin)
    ds = sum(a_sin * 2 * np.pi * f * np.cos(2 * np.pi * f * t) for f in f_sin)
    return tri + s, dtri + ds


# ---- experiments ---------------------------------------------------------------------------------

def constant_velocity(device, transmission: int | None = None, speeds=None, strategy: str = "S2",
                      travel: float = 20.0, accel: float = 200.0, q0=None, rate_hz: float = 10_000.0,
                      control_hz: float | None = None, log_rate_hz: float = 1_000.0, seed: int = 0,
                      bandwidth_hz: float = LOOP_BANDWIDTH_HZ, progress=None,
                      test: ConstantVelocityTest | None = None) -> SimRun:
    """Constant-velocity moves of one transmission (S0 §III-A) at several motor speeds.

    Parameters
    ----------
    transmission : 1-based transmission number
    speeds : motor speeds [rad/s]
    strategy : "S1" — every other motor held at zero speed (motor-space PID);
               "S2" — every other joint held at zero speed (joint-space PID)
    travel : motor travel per stroke [rad]
    test : a planned test (:func:`tendyn.protocols.plan_test`: strokes inside the limits, one or more poses for
        the load); when given it replaces transmission, speeds, strategy, travel, accel and q0
    """
    if test is not None:
        transmission, speeds, strategy = test.transmission, test.speeds, test.strategy
        travel, accel, q0 = test.travel, test.accel, test.poses[0]
    if strategy not in ("S1", "S2"):
        raise ValueError(f"strategy must be 'S1' or 'S2' (got {strategy!r})")
    device = compile_device(device)   # built once: sim model, PID gains and log share it
    m = sim_model(device, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    na = m.na
    _check_index(transmission, na, "transmission")
    given_q0 = q0
    q0 = np.zeros(na) if q0 is None else np.asarray(q0, float)
    if m.drive == _core.DriveKind.Tendons and (strategy == "S1" or (test is not None and test.strategy == "S1")):
        raise UsageError("S1 holds every other motor still: with N+1 rigid tendons n motors already fix every "
                         "joint; use --strategy S2 (joint space)", "strategy")
    Gm = np.array(m.Gm) if m.drive != _core.DriveKind.Elastic else np.diag(m.ratio)
    if m.drive == _core.DriveKind.Tendons and test is None:
        # N+1 (S2): joint `transmission` strokes over at most 80 % of its range from 10 % above its lower limit,
        # the other joints held mid-range; travel is on the fastest motor of that joint (protocols' scale)
        j = transmission - 1
        lo, hi = _active_limits(device)
        if given_q0 is None:
            q0 = 0.5 * (lo + hi)
            q0[j] = lo[j] + 0.1 * (hi[j] - lo[j])
        travel = min(travel, 0.8 * (hi[j] - lo[j]) * np.abs(Gm[:, j]).max())
    if test is None:
        ref_q, ref_qd, space = constant_velocity_references(Gm, transmission, speeds, strategy, travel, accel, q0,
                                                            m.dt)
    else:
        ref_q, ref_qd, space = cv_references(Gm, test, m.dt)
    n = ref_q.shape[0]
    m.mode = _core.ControlMode.MotorPID if space == "motor" else _core.ControlMode.JointPID
    m.kp, m.kd, m.ki = pid_gains(m, device, q0, bandwidth_hz, space=space)
    m.velocity_cutoff_hz = 100.0
    ff = np.zeros((n, m.n_ff))
    opts = dict(transmission=transmission, strategy=strategy, speeds_motor=list(map(float, speeds)),
                travel_motor=travel, accel_motor=accel, q0=q0, bandwidth_hz=bandwidth_hz,
                rate_hz=rate_hz, control_hz=control_hz)
    if test is not None:
        opts.update(test.options())
    return run_on_twin(device, m, q0, ref_q, ref_qd, ff, None, seed=seed, experiment=f"constant_velocity_{strategy}",
                       options=opts, log_rate_hz=log_rate_hz, reference_space=space, progress=progress)


def smooth_triangle(t, freq: float, amplitude: float, phase: float = 0.0, sharpness: float = 0.1):
    """Triangle wave ± ``amplitude`` with rounded corners: constant-velocity segments (S2 §VI: "triangular
    positions give constant velocities") joined by reversals of finite acceleration.

    With x = 2π(f t + phase) and P(x) = ∫ tanh(cos x / ε) dx (ε = ``sharpness``; ε → 0 gives the sharp
    triangle of :func:`triangle_wave`), q = s P(x), q̇ = 2π f s tanh(cos x / ε),
    q̈ = −(2π f)² s sin x / (ε cosh²(cos x / ε)), s = amplitude / max P. Returns (q, qd, qdd)."""
    t = np.asarray(t, float)
    x = 2 * np.pi * (freq * t + phase)
    eps = float(sharpness)
    xs = np.linspace(-np.pi / 2, 3 * np.pi / 2, 4097)      # one period, P(-π/2) = minimum
    g = np.tanh(np.cos(xs) / eps)
    prof = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(xs))])
    prof = prof - 0.5 * (prof.max() + prof.min())
    s = amplitude / prof.max()
    w = 2 * np.pi * freq
    q = s * np.interp(np.mod(x + np.pi / 2, 2 * np.pi) - np.pi / 2, xs, prof)
    qd = w * s * np.tanh(np.cos(x) / eps)
    qdd = -w * w * s * np.sin(x) / (eps * np.cosh(np.cos(x) / eps) ** 2)
    return q, qd, qdd


def smooth_triangle_scale(amplitude: float, sharpness: float = 0.1) -> float:
    """The scale s of :func:`smooth_triangle` (its cruise speed is 2π f s) [rad]."""
    t = np.linspace(0.0, 1.0, 2, endpoint=False)
    q, qd, _ = smooth_triangle(t, 1.0, amplitude, 0.0, sharpness)
    return float(abs(qd[0]) / (2 * np.pi))


@dataclass(frozen=True)
class ExcitingDesign:
    """An exciting trajectory of S2 §VI: along each mode a rounded triangle (constant velocities: gravity and
    friction) plus sines (sinusoidal accelerations: inertia), every frequency inside the identification band;
    the active joints are q = center + modes @ u(t).

    Attributes (SI units, joint side)
    ---------------------------------
    center : (na,) [rad]
    modes : (na, nm) directions in active-joint space [-] (identity for a serial device; for a parallelogram the
        free common motion and the differential motion that bends the passive joints, see :func:`excitation_modes`)
    tri_amplitude, tri_freq_hz, tri_phase : (nm,) [rad], [Hz], [cycles]
    sin_amplitude, sin_freq_hz, sin_phase : (nm, n_sin) [rad], [Hz], [cycles]
    band_hz : (low, high) [Hz] the identification band the frequencies were chosen in
    ramp_s : fade-in [s] of the excursions (the run starts at rest on ``center``)
    speed_span : ρ ∈ [0, 1) [-]; 0 (default) runs every mode at its own constant pace. ρ > 0 warps each mode's
        time, u_k(t) = e_k(θ_k(t)) with θ̇_k = g_k(t) = 1 − ρ/2 + ρ/2 cos(2π f_w,k t) ∈ [1 − ρ, 1]: the path
        (hence the limits) is unchanged, every velocity of the mode (triangle cruise and sines alike) is scaled
        by g_k, so the cruise speeds sweep [1 − ρ, 1] × the design's and the sines still reverse only at the
        corners; q̇ ≤ the unwarped bound (``peak_speed``), q̈ = e'' g² + e' ġ.
    span_hz : (nm,) f_w,k [Hz], the warp's frequency per mode (None when ρ = 0)
    """

    center: np.ndarray
    modes: np.ndarray
    tri_amplitude: np.ndarray
    tri_freq_hz: np.ndarray
    tri_phase: np.ndarray
    sin_amplitude: np.ndarray
    sin_freq_hz: np.ndarray
    sin_phase: np.ndarray
    band_hz: tuple
    ramp_s: float = 2.0
    sharpness: float = 0.1
    speed_span: float = 0.0
    span_hz: np.ndarray | None = None

    @property
    def n_phases(self) -> int:
        return self.tri_phase.size + self.sin_phase.size

    def with_phases(self, phases) -> "ExcitingDesign":
        """The same design with other phases [cycles]: triangles first, then the sines row by row (the free
        variables of :func:`tendyn.pipelines.s2.optimise_exciting`)."""
        import dataclasses

        p = np.asarray(phases, float)
        nt = self.tri_phase.size
        return dataclasses.replace(self, tri_phase=p[:nt], sin_phase=p[nt:].reshape(self.sin_phase.shape))

    def phases(self) -> np.ndarray:
        return np.concatenate([self.tri_phase, self.sin_phase.ravel()])

    def mode_excursion(self) -> np.ndarray:
        """Largest excursion of each mode coordinate [rad] (triangle + every sine in phase)."""
        return self.tri_amplitude + self.sin_amplitude.sum(axis=1)

    def peak_speed(self) -> np.ndarray:
        """Upper bound of |q̇| per active joint [rad/s]."""
        # the rounded triangle cruises at 2π f s, s = A / max P ≈ 4 A f × 1.1 for ε = 0.1
        mode = 4.4 * self.tri_amplitude * self.tri_freq_hz + (2 * np.pi * self.sin_amplitude * self.sin_freq_hz).sum(axis=1)
        return np.abs(self.modes) @ mode

    def references(self, duration: float, dt: float):
        """(q, qd, qdd) of shape (n, na) on the grid dt [s] (n = duration / dt)."""
        t = np.arange(int(round(duration / dt))) * dt
        nm = self.tri_amplitude.size
        u, ud, udd = (np.zeros((t.size, nm)) for _ in range(3))
        # fade-in w(t) = (1 - cos(pi t / T)) / 2 on the excursions: e(t) w(t), derivatives by the product rule
        T = max(self.ramp_s, 1e-9)
        w = np.where(t < T, 0.5 * (1 - np.cos(np.pi * t / T)), 1.0)
        wd = np.where(t < T, 0.5 * np.pi / T * np.sin(np.pi * t / T), 0.0)
        wdd = np.where(t < T, 0.5 * (np.pi / T) ** 2 * np.cos(np.pi * t / T), 0.0)
        rho = float(self.speed_span)
        for k in range(nm):
            if rho > 0.0:      # time warp θ(t), θ̇ = g ∈ [1 − ρ, 1] (class docstring)
                wk = 2 * np.pi * float(self.span_hz[k])
                tau = (1 - rho / 2) * t + rho / 2 * np.sin(wk * t) / wk
                g = 1 - rho / 2 + rho / 2 * np.cos(wk * t)
                gd = -rho / 2 * wk * np.sin(wk * t)
            else:
                tau, g, gd = t, 1.0, 0.0
            e, ed, edd = smooth_triangle(tau, self.tri_freq_hz[k], self.tri_amplitude[k], self.tri_phase[k],
                                         self.sharpness)
            for a, f, ph in zip(self.sin_amplitude[k], self.sin_freq_hz[k], self.sin_phase[k]):
                x = 2 * np.pi * (f * tau + ph)
                e = e + a * np.sin(x)
                ed = ed + a * 2 * np.pi * f * np.cos(x)
                edd = edd - a * (2 * np.pi * f) ** 2 * np.sin(x)
            ed, edd = ed * g, edd * g * g + ed * gd         # d/dt of e(θ(t)): chain rule
            u[:, k] = w * e
            ud[:, k] = w * ed + wd * e
            udd[:, k] = w * edd + 2 * wd * ed + wdd * e
        M = self.modes.T
        return self.center + u @ M, ud @ M, udd @ M

    def to_dict(self) -> dict:
        return to_jsonable({k: getattr(self, k) for k in ("center", "modes", "tri_amplitude", "tri_freq_hz",
                                                          "tri_phase", "sin_amplitude", "sin_freq_hz", "sin_phase",
                                                          "band_hz", "ramp_s", "sharpness", "speed_span",
                                                          "span_hz")})


def stops_touched(device, q_active) -> list[int]:
    """1-based numbers (device file ``j``) of the tree joints that ``q_active`` (samples, na) [rad] takes past
    their limits (the twin's end stops)."""
    from tendyn.device.rigid_body import tree_joint_numbers

    lo, hi, L, c = tree_limits(device)
    qt = np.atleast_2d(np.asarray(q_active, float)) @ L.T + c
    out = np.any((qt < lo - 1e-9) | (qt > hi + 1e-9), axis=0)
    numbers = tree_joint_numbers(compile_device(device).device)
    return [int(numbers[k]) for k in np.flatnonzero(out)]


def torque_mode_start(device, m: _core.SimModel, q0=None) -> np.ndarray:
    """Start pose [rad] of a torque-mode test (stepped or swept sine) and its gravity compensation: ``q0``, else
    the device file's ``home_pose`` when it has one inside the limits, else q = 0 when every tree joint is inside its limits there, else the pose nearest (least squares) the middle of
    every tree joint's range; an arm under gravity gets the controller's gravity compensation
    (``SimModel.gravity_compensation``: the lossless motor torques of g at the encoder estimate), so the test
    excites the arm about that pose instead of letting it fall into its stops. Raises ValueError when the pose
    is outside the limits."""
    lo, hi, L, c = tree_limits(device)
    home = getattr(compile_device(device).device, "home_pose", None)
    if q0 is None and home is not None and len(home) == m.na and not stops_touched(device, np.asarray(home, float)):
        q0 = home                       # the device's own rest pose (its file's home_pose) when it has one
    if q0 is None:
        q = np.zeros(m.na)
        if stops_touched(device, q):
            mid = np.where(np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), 0.0)
            q = np.linalg.lstsq(L, mid - c, rcond=None)[0]
    else:
        q = np.asarray(q0, float)
    bad = stops_touched(device, q)
    if bad:
        raise ValueError(f"{compile_device(device).name}: the start pose puts joint(s) {bad} outside their limits")
    dev = compile_device(device).device
    m.gravity_compensation = bool(np.linalg.norm(np.asarray(dev.kinematics.gravity, float)) > 0.0)
    return q


def require_free(runs, what: str) -> None:
    """Refuse a frequency response measured while the twin sat on an end stop (``meta.options.end_stops``): it
    would be the stop's response, coherent and wrong. Raises ValueError naming the joints."""
    for r in runs:
        stops = (r.log.meta.get("options") or {}).get("end_stops")
        if stops:
            raise ValueError(f"{what}: the arm met its end stop(s) at joint(s) {stops['joints']} for "
                             f"{stops['contact_s']:.3g} s: the response would be the stop's, not the arm's "
                             "(smaller torque, or another q0)")


def tree_limits(device) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Joint limits of every tree joint (active and passive) and the map q_tree = L q_active + c:
    (lower, upper, L, c) [rad]."""
    from tendyn.device.rigid_body import tree_joint_numbers

    compiled = compile_device(device)
    joints = compiled.device.kinematics.joints
    numbers = tree_joint_numbers(compiled.device)
    L, c = compiled.active_map
    lo = np.array([joints[n - 1].lower for n in numbers], float)
    hi = np.array([joints[n - 1].upper for n in numbers], float)
    return lo, hi, np.asarray(L, float), np.asarray(c, float)


def excitation_modes(device) -> np.ndarray:
    """Directions (na, na) in active-joint space for an exciting trajectory: first the motions that leave every
    limited passive joint still (each active axis projected on that null space, in order, orthonormalised),
    then those that move them (the row space of their rows of L). For a serial device: the identity. On the
    CEA parallelogram: q1 alone, q2 and q5 together (q3 = q5 − q2 still, eq. 8), then q5 − q2."""
    lo, hi, L, _ = tree_limits(device)
    na = L.shape[1]
    passive = [k for k in range(L.shape[0]) if np.count_nonzero(np.abs(L[k]) > 1e-12) != 1 or
               abs(np.abs(L[k]).sum() - 1.0) > 1e-12]
    passive = [k for k in passive if hi[k] - lo[k] < 2 * np.pi - 1e-9]
    if not passive:
        return np.eye(na)
    P = L[passive]
    U, sv, Vt = np.linalg.svd(P)
    rank = int(np.sum(sv > 1e-9 * sv.max()))
    row = Vt[:rank].T
    proj = np.eye(na) - row @ row.T
    basis = []
    for i in range(na):
        v = proj[:, i].copy()
        for b in basis:
            v -= (b @ v) * b
        if np.linalg.norm(v) > 1e-9:
            basis.append(v / np.linalg.norm(v))
    for v in row.T:
        basis.append(v * np.sign(v[np.argmax(np.abs(v))]))
    return np.column_stack(basis[:na])


SPAN_PERIODS = 4.0
"""Triangle periods (at full pace) per cycle of the speed warp of ``design_exciting(…, speed_span=ρ)``: every
cruise speed level is held for about one triangle period."""


def design_exciting(device, band_hz=(0.1, 2.0), n_sin: int = 3, sin_share: float = 0.25, max_speed: float = 1.5,
                    margin: float = 0.1, seed: int = 0, modes=None, sine_speed_ratio: float | None = 0.8,
                    tri_freq_factors=(1.5, 2.0, 2.5), speed_span: float | None = None) -> ExcitingDesign:
    """An :class:`ExcitingDesign` that keeps every tree joint (passive ones too: q_tree = L q_a + c) inside its
    limits less ``margin`` [rad], and every active joint below ``max_speed`` [rad/s].

    Centre and mode excursions R_k come from two linear programs on q = center + M u, |u_k| ≤ R_k (a tree joint
    moves by at most Σ_k |(L M)_jk| R_k): (1) the largest common excursion t (all R_k = t); (2) keeping R_k ≥ t,
    the largest Σ R_k. Frequencies: triangles at distinct low frequencies band_lo × (1, 1.37, 1.74, …) [Hz]
    (slow sweeps over the whole range: gravity and offsets separate, friction sees constant speeds); sines on
    nm × n_sin distinct frequencies over [band_hi / 4, band_hi] dealt to the modes in turn (no two modes share
    one), amplitudes ∝ 1 / f, ``sin_share`` of R_k; sines are scaled down until the joints' peak speed is below
    ``max_speed``. With ``sine_speed_ratio`` r (default 0.8) the sines of a mode are also scaled so that their
    summed velocity amplitude stays below r × the triangle's cruise speed: the velocity then changes sign only at
    the triangles' rounded corners (a few times per minute), not on every sine cycle. On a capstan drive the
    dry friction sits at the motor, behind the cable spring: at each reversal the motor sticks while the
    spring winds up by 2 F_c / K (S2 Fig. 4), which the rigid model's F_C sign(q̇) does not describe; with
    reversals on every sine cycle this biased ZZ3R by +4 % and FV5 by +12 % on the CEA twin (ideal sensors),
    a few reversals make it negligible. Triangle frequencies band_lo × ``tri_freq_factors`` [Hz].
    Phases: seeded uniform draws (see :func:`tendyn.pipelines.s2.optimise_exciting` to improve cond(W)).

    ``speed_span`` ρ ∈ [0, 1) (None, the default: off): each mode's time is warped so that its speeds sweep
    [1 − ρ, 1] × the design's, once every 1 / f_w,k s, f_w,k = f_tri,k / SPAN_PERIODS (:class:`ExcitingDesign`).
    With one cruise speed per joint the Coulomb column F_C sign(q̇) and the viscous column F_V q̇ of the
    regressor are nearly proportional on the cruise rows (only the sines tell them apart); spread speeds
    separate them (docs/device-file.md, the numbers). Positions, limits and the speed bound are unchanged; the
    frequencies slow to (1 − ρ)× at the slow end (below band_lo when the triangles sit near it, as in the default
    design). It pays only when the cruise speeds are high and the log long (≥ 60 s): :func:`design_fast`, the default
    on elastic capstan drives, sets ρ = :data:`FAST_SPEED_SPAN`.
    """
    from scipy.optimize import linprog

    if speed_span is not None and not 0.0 <= float(speed_span) < 1.0:
        raise ValueError(f"speed_span must be in [0, 1) (got {speed_span!r}): the slowest pace is 1 − speed_span")

    lo, hi, L, c = tree_limits(device)
    na = L.shape[1]
    M = excitation_modes(device) if modes is None else np.asarray(modes, float)
    nm = M.shape[1]
    LM = L @ M
    A = np.abs(LM)
    b_ub = np.concatenate([hi - margin - c, -(lo + margin) + c])
    # (1) common excursion t: variables [q_c (na), t]
    A1 = np.vstack([np.hstack([L, A.sum(axis=1, keepdims=True)]), np.hstack([-L, A.sum(axis=1, keepdims=True)])])
    r1 = linprog(np.r_[np.zeros(na), -1.0], A_ub=A1, b_ub=b_ub, bounds=[(None, None)] * na + [(0, None)])
    if not r1.success or r1.x[-1] <= 0:
        raise ValueError("the joint limits leave no room for an exciting trajectory")
    t_common = float(r1.x[-1])
    # (2) variables [q_c (na), R (nm)]
    A2 = np.vstack([np.hstack([L, A]), np.hstack([-L, A])])
    r2 = linprog(np.r_[np.zeros(na), -np.ones(nm)], A_ub=A2, b_ub=b_ub,
                 bounds=[(None, None)] * na + [(t_common * 0.999, None)] * nm)
    x = r2.x if r2.success else np.r_[r1.x[:na], np.full(nm, t_common)]
    center, R = x[:na], x[na:]
    f_lo, f_hi = band_hz
    factors = np.asarray(tri_freq_factors, float)
    tri_f = f_lo * (factors[np.arange(nm) % factors.size] + 0.37 * (np.arange(nm) // factors.size))
    grid = np.linspace(f_hi / 4, f_hi, nm * n_sin)
    sin_f = np.array([grid[k::nm] for k in range(nm)])
    rng = np.random.default_rng(seed)
    weights = 1.0 / sin_f
    sin_a = sin_share * R[:, None] * weights / weights.sum(axis=1, keepdims=True)
    tri_a = (1 - sin_share) * R
    design = ExcitingDesign(center, M, tri_a, tri_f, rng.uniform(0, 1, nm), sin_a, sin_f,
                            rng.uniform(0, 1, (nm, n_sin)), (float(f_lo), float(f_hi)))
    # speed bound: scale the sines (then, if needed, the triangles) down
    import dataclasses

    tri_only = dataclasses.replace(design, sin_amplitude=0 * sin_a).peak_speed()
    if np.any(tri_only > max_speed):
        design = dataclasses.replace(design, tri_amplitude=tri_a * (0.5 * max_speed / tri_only.max()))
        tri_only = dataclasses.replace(design, sin_amplitude=0 * sin_a).peak_speed()
    sin_only = design.peak_speed() - tri_only
    k = np.min(np.where(sin_only > 0, (max_speed - tri_only) / np.maximum(sin_only, 1e-300), np.inf))
    sin_a = design.sin_amplitude * min(1.0, float(k))
    if sine_speed_ratio is not None:
        cruise = 2 * np.pi * design.tri_freq_hz * np.array([smooth_triangle_scale(a) for a in design.tri_amplitude])
        sine_speed = (2 * np.pi * sin_a * design.sin_freq_hz).sum(axis=1)
        sin_a = sin_a * np.minimum(1.0, sine_speed_ratio * cruise / np.maximum(sine_speed, 1e-300))[:, None]
    span = float(speed_span or 0.0)
    return dataclasses.replace(design, sin_amplitude=sin_a, speed_span=span,
                               span_hz=design.tri_freq_hz / SPAN_PERIODS if span > 0.0 else None)


FAST_TRI_FREQ_FACTORS = (8.0, 10.0, 12.0)
"""Triangle frequencies of the fast design (:func:`design_fast`), × the band's low end: 0.8, 1.0 and 1.2 Hz in the
default 0.1–2 Hz band. Generated arms 0–2, 5 phase seeds each, 120 s: FV within 6.2 %, σ(FV) 0.7–3.0 %; (6, 8, 10)
gave within 7.5 %, σ 0.9–3.5 %; (10, 13, 16) σ 1.0–2.4 % but a base FV +7.9 % (4σ) (docs/device-file.md)."""

FAST_SPEED_SPAN = 0.8
"""speed_span ρ of the fast design: its cruise speeds sweep [0.2, 1] × the design's (Coulomb and viscous columns
apart, :class:`ExcitingDesign`)."""

FAST_DURATION_S = 120.0
"""Default length [s] of an exciting run with the fast design (``tendyn simulate … exciting`` on a device with
elastic capstan drives, tendyn.sim.catalogue): on generated arms 0–2 (5 phase seeds each, triangles (6, 8, 10) ×
0.1 Hz) FV within 7.5 % at 120 s, σ(FV) 0.9–3.5 %; at 60 s one log in 15 missed by 16 % (σ 4–6 %)."""

DEFAULT_DURATION_S = 20.0
"""Default length [s] of an exciting run with the band or classic design (every other device)."""

TORQUE_CHECK_S = 40.0
"""Seconds of a design (from its start) on which :func:`design_motor_torques` evaluates the motor torques."""

FAST_SPEED_FLOOR = 0.01
"""Slowest fast design :func:`design_fast` offers, × the speed of the unbounded one: below it the motors fail on the
gravity and Coulomb torques, which do not shrink with the speed (a design that slow excites nothing either). Motors
that cannot hold the arm were refused after all 40 bound iterations, 3 s on a generated arm; now after 3."""


def default_design(device) -> str:
    """The exciting design ``exciting_trajectory(design=None)`` runs on ``device``: "fast" on elastic capstan
    ``[[drives]]`` (``SerialDevice.elastic_drives``: the viscous friction is only seen above the current noise at
    speeds of rad/s, docs/device-file.md), "band" when the file gives ``bandwidth_hz`` or the device has passive
    tree joints (a parallelogram), else "classic"."""
    compiled = compile_device(device)
    if getattr(compiled.device, "elastic_drives", False):
        return "fast"
    passive = tree_limits(compiled)[2].shape[0] > compiled.active_map[0].shape[1]
    if getattr(compiled.device, "bandwidth_hz", None) or passive:
        return "band"
    return "classic"


def default_duration(device, design=None) -> float:
    """Default length [s] of an exciting run on ``device`` with ``design`` (None: :func:`default_design`):
    :data:`FAST_DURATION_S` with the fast design, else :data:`DEFAULT_DURATION_S` (the one rule
    ``exciting_trajectory`` and ``tendyn simulate`` follow)."""
    name = default_design(device) if design is None else design
    return FAST_DURATION_S if isinstance(name, str) and name == "fast" else DEFAULT_DURATION_S


def design_motor_torques(device, design, seconds: float = TORQUE_CHECK_S, dt: float = 2e-3):
    """The motor torques [N·m] a design asks of the capstan drives, by the device file's model: rigid-body
    inverse dynamics of the tree (Pinocchio, q_tree = L q + c, τ = Lᵀ τ_tree), each drive's rotor inertia,
    Coulomb and viscous friction at the motor (τ_m = τ/N + J_r N q̈ + C_m sign(q̇) + ν_m N q̇; ``[[terms]]`` and the
    cable's own dynamics left out), over the first ``seconds`` of the design on the grid ``dt`` [s].
    Returns (peak, rms), each (n_drives,)."""
    compiled = compile_device(device)
    drives = compiled.device.drives
    q, qd, qdd = design.references(seconds, dt)
    L, c = (np.ascontiguousarray(a, float) for a in compiled.active_map)
    # τ = Lᵀ rnea(L q + c, L q̇, L q̈) for every sample in one core call: rigid-body inverse dynamics is linear in the
    # tree's ten inertial parameters per body (Pinocchio's joint-torque regressor, the first 10 columns per body of
    # the identification regressor, rows joint-major) times the device file's values: 0.09 s for the 20 000 samples
    # of a generated arm against 0.15 s for a Python loop of pin.rnea, and up to 40 calls per fast design
    G = np.ascontiguousarray(compiled.device.motor_joint_matrix(), float)
    W = _core.identification_regressor(compiled.rigid_body, _core.RigidBodyData(compiled.rigid_body), L, c, G,
                                       *(np.ascontiguousarray(x, float) for x in (q, qd, qdd)), np.ones(1), 1, 1)
    params = standard_parameters(compiled.device)[1]
    tau = (W[:, :params.size] @ params).reshape(q.shape[1], q.shape[0]).T
    N = np.array([d.ratio for d in drives], float)
    Jr = np.array([d.motor.rotor_inertia for d in drives], float)
    Cm = np.array([d.coulomb_motor for d in drives], float)
    nu = np.array([d.viscous_motor for d in drives], float)
    tm = tau / N + Jr * N * qdd + Cm * np.sign(qd) + nu * N * qd
    return np.abs(tm).max(axis=0), np.sqrt((tm ** 2).mean(axis=0))


def design_fast(device, band_hz=(0.1, 2.0), seed: int = 0) -> tuple[ExcitingDesign, dict]:
    """The fast exciting design for elastic capstan drives: :func:`design_exciting` with triangles at band_lo ×
    :data:`FAST_TRI_FREQ_FACTORS` and spread cruise speeds (``speed_span`` :data:`FAST_SPEED_SPAN`), every tree
    joint inside its limits; its speeds set by those frequencies over the joint ranges, bounded by the motors:
    the device file gives no speed limit, so the bound is the largest at which the model's motor torques
    (:func:`design_motor_torques`) stay within each motor's ``peak_torque`` and their rms within its
    ``continuous_torque`` (inertial torques grow as the square of the speed: the bound shrinks by 0.9/√excess
    until they do). Returns (design, record): the record (``kind``, ``tri_freq_factors``, ``speed_bound``
    [rad/s] or None when the torques never bound it, ``motor_torque_peak`` / ``motor_torque_rms`` [N·m]) goes to
    the log's ``options.design``. Raises ValueError when the motors cannot follow it at any speed (gravity), i.e. not
    above :data:`FAST_SPEED_FLOOR` × the unbounded design's speed."""
    compiled = compile_device(device)
    drives = compiled.device.drives
    if not drives:
        raise ValueError(f"{compiled.name}: the fast exciting design is for capstan [[drives]] (its speed bound is "
                         "their motors' torques); use the 'band' or 'classic' design")
    peak_lim = np.array([d.motor.peak_torque for d in drives], float)
    cont_lim = np.array([d.motor.continuous_torque for d in drives], float)
    bound, unbounded = math.inf, None
    for _ in range(40):
        design = design_exciting(compiled, band_hz=band_hz, seed=seed, tri_freq_factors=FAST_TRI_FREQ_FACTORS,
                                 max_speed=bound, speed_span=FAST_SPEED_SPAN)
        speed = float(design.peak_speed().max())
        unbounded = speed if unbounded is None else unbounded
        peak, rms = design_motor_torques(compiled, design)
        excess = float(max(np.max(peak / peak_lim), np.max(rms / cont_lim)))
        if excess <= 1.0:
            return design, {"kind": "fast", "tri_freq_factors": list(FAST_TRI_FREQ_FACTORS),
                            "speed_bound": None if math.isinf(bound) else float(bound),
                            "motor_torque_peak": peak.tolist(), "motor_torque_rms": rms.tolist()}
        bound = 0.9 * speed / math.sqrt(excess)
        if bound < FAST_SPEED_FLOOR * unbounded:
            break
    i = int(np.argmax(np.maximum(peak / peak_lim, rms / cont_lim)))
    raise ValueError(f"{compiled.name}: motor {i + 1} cannot follow an exciting trajectory within its torques "
                     f"(peak {peak[i]:.3g} of {peak_lim[i]:.3g} N·m, rms {rms[i]:.3g} of {cont_lim[i]:.3g} N·m at "
                     f"{speed:.3g} rad/s): gravity alone is too much for it")


def exciting_trajectory(device, duration: float | None = None, amplitude: float = 0.4, q0=None, f_tri: float = 0.25,
                        f_sin=(0.5, 1.1, 1.7), a_sin: float = 0.05, rate_hz: float = 5_000.0,
                        control_hz: float | None = None, log_rate_hz: float = 1_000.0, seed: int = 0,
                        bandwidth_hz: float = 8.0, design: "ExcitingDesign | str | None" = None,
                        progress=None, friction: bool = True) -> SimRun:
    """Triangular + sinusoidal joint trajectories (S2 §VI) tracked by a joint-space PID.

    duration : [s]; None: :func:`default_duration` (120 s with the fast design, else 20 s)
    design : ExcitingDesign, FourierDesign (:func:`tendyn.ident.exciting.plan_exciting`), "fast", "band",
        "classic" or None (:func:`default_design`). "fast": :func:`design_fast` in the band 0.1 Hz …
        ``device.bandwidth_hz`` (2 Hz when the file gives none), the default on elastic capstan ``[[drives]]``.
        "classic": one triangle per joint (``amplitude`` [rad], ``f_tri`` [Hz]) plus the sines ``f_sin`` [Hz]
        of ``a_sin`` [rad] shared by all joints, clipped inside the active joint limits. "band": the design of
        :func:`design_exciting` inside the device's identification band (0.1 Hz … ``device.bandwidth_hz``),
        passive joints kept inside their limits, distinct frequencies per joint (``q0``, ``amplitude``,
        ``f_tri``, ``f_sin``, ``a_sin`` unused). None: "fast" on elastic capstan drives; else "band" when the
        device file gives ``bandwidth_hz`` (its motion bandwidth) or has passive tree joints (a parallelogram:
        "classic" drove a desktop arm's elbow into its end stops for 0.6 s of 20, the stop forces in the log,
        σ(FV) 1.4–3.6× FV), else "classic". The log records the design (``options.design``; a string design
        adds its ``kind``, the fast one its speed bound and the model's motor torques).
    friction : False runs the twin without its friction sources (a rigid-body-plus-terms truth).
    """
    device = compile_device(device)   # built once: sim model, PID gains and log share it
    m = sim_model(device, rate_hz=rate_hz, control_hz=control_hz, friction=friction, stops=True)
    na = m.na
    dev_bw = getattr(device.device, "bandwidth_hz", None)
    if design is None:      # "classic" clips the active limits only: passive tree joints would ride their stops
        design = default_design(device)
    if duration is None:
        duration = default_duration(device, design)
    record = {}
    if isinstance(design, str) and design == "fast":
        design, record = design_fast(device, band_hz=(0.1, float(dev_bw or 2.0)), seed=seed)
    elif isinstance(design, str) and design == "band":
        design, record = design_exciting(device, band_hz=(0.1, float(dev_bw or 2.0)), seed=seed), {"kind": "band"}
    if not isinstance(design, str) and hasattr(design, "references"):   # ExcitingDesign, ident.exciting.FourierDesign
        ref_q, ref_qd, _ = design.references(duration, m.dt)
        q0 = design.center
        opts = dict(duration=duration, design={**design.to_dict(), **record}, rate_hz=rate_hz,
                    control_hz=control_hz)
    elif design == "classic":
        lo, hi = _active_limits(device)
        q0 = 0.5 * (lo + hi) if q0 is None else np.asarray(q0, float)
        refs, vels = [], []
        for i in range(na):
            room = max(0.0, min(q0[i] - lo[i], hi[i] - q0[i]) - a_sin * len(f_sin) - 0.05)
            p, v = triangle_sine_profile(duration, m.dt, min(amplitude, room), f_tri * (1 + 0.17 * i), f_sin,
                                         a_sin, phase=0.1 * i)
            refs.append(q0[i] + p)
            vels.append(v)
        ref_q, ref_qd = np.column_stack(refs), np.column_stack(vels)
        opts = dict(duration=duration, amplitude=amplitude, f_tri=f_tri, f_sin=list(f_sin), a_sin=a_sin, q0=q0,
                    rate_hz=rate_hz, control_hz=control_hz)
    else:
        raise ValueError(f"design must be an ExcitingDesign, 'fast', 'band' or 'classic' (got {design!r})")
    m.mode = _core.ControlMode.JointPID
    m.kp, m.kd, m.ki = pid_gains(m, device, q0, bandwidth_hz)
    m.velocity_cutoff_hz = 100.0
    return run_on_twin(device, m, ref_q[0], ref_q, ref_qd, np.zeros_like(ref_q), None, seed=seed,
                       experiment="exciting", options=opts, log_rate_hz=log_rate_hz, reference_space="joint",
                       progress=progress)


def blocked_link(device, joint: int, torque_amplitude: float, period: float = 2.0, cycles: int = 3, q0=None,
                 rate_hz: float = 10_000.0, control_hz: float | None = None, log_rate_hz: float = 1_000.0,
                 seed: int = 0, progress=None) -> SimRun:
    """Blocked-link test (S2 §V-C): every link blocked, triangular motor torque [N·m] on one motor;
    the motor rotates against the cable/capstan stiffness (and its friction: hysteresis)."""
    device = compile_device(device)   # built once: sim model, PID gains and log share it
    m = sim_model(device, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    na = m.na
    _check_index(joint, na, "joint")
    m.lock_joint = np.ones(na)
    m.finalize()
    q0 = np.zeros(na) if q0 is None else np.asarray(q0, float)
    n = int(round(cycles * period / m.dt))
    t = np.arange(n) * m.dt
    tri, _ = triangle_wave(t, 1.0 / period, torque_amplitude)
    ff = np.zeros((n, na))
    ff[:, joint - 1] = tri
    m.mode = _core.ControlMode.Torque
    opts = dict(joint=joint, torque_amplitude=torque_amplitude, period=period, cycles=cycles, q0=q0)
    return run_on_twin(device, m, q0, np.tile(q0, (n, 1)), np.zeros((n, na)), ff, None, seed=seed,
                       experiment="blocked_link", options=opts, log_rate_hz=log_rate_hz, progress=progress)


def stepped_sine(device: Device | CompiledDevice, transmission: int, *, omega, amplitude: float,
                 cycles: int = 6, q0=None, rate_hz: float = 10_000.0, control_hz: float = 10_000.0, seed: int = 0,
                 progress=None) -> list[SimRun]:
    """Sinusoidal motor torque [N·m] on one transmission at each frequency of ``omega`` [rad/s]
    (keyword-only), torque mode, links free: one run per frequency (see :func:`stepped_sine_response`)."""
    device = compile_device(device)   # compiled once for every frequency
    runs = []
    for w in np.asarray(omega, float).ravel():
        f = w / (2 * math.pi)
        m = sim_model(device, rate_hz=rate_hz, control_hz=control_hz, stops=True)
        na = m.na
        _check_index(transmission, na, "transmission")
        q = torque_mode_start(device, m, q0)
        n = int(round(cycles / f / m.dt))
        t = np.arange(n) * m.dt
        ff = np.zeros((n, na))
        ff[:, transmission - 1] = amplitude * np.sin(w * t)
        m.mode = _core.ControlMode.Torque
        opts = dict(transmission=transmission, omega=float(w), freq_hz=float(f), amplitude=amplitude,
                    cycles=cycles, q0=q)
        runs.append(run_on_twin(device, m, q, np.tile(q, (n, 1)), np.zeros((n, na)), ff, None, seed=seed,
                                experiment="stepped_sine", options=opts, log_rate_hz=control_hz,
                                progress=progress))
    return runs


def first_harmonic_ratio(log, output: str, input: str, omega: float, skip: float = 0.5) -> complex:
    """First harmonic of log column ``output`` over that of ``input`` at ``omega`` [rad/s] (lock-in over the
    whole cycles after the first ``skip`` fraction of the record, the mean removed)."""
    t = np.asarray(log.time, float)
    period = 2 * math.pi / omega
    start = t[0] + skip * (t[-1] - t[0])
    whole = math.floor((t[-1] - start) / period)
    if whole < 1:
        raise ValueError(f"the record is shorter than one period after the settling part ({period:.3g} s)")
    sel = (t >= start) & (t < start + whole * period)
    kernel = np.exp(-1j * omega * t[sel])
    y, x = np.asarray(log[output], float)[sel], np.asarray(log[input], float)[sel]
    return complex(np.dot(y - y.mean(), kernel) / np.dot(x - x.mean(), kernel))


def stepped_sine_response(device: Device | CompiledDevice, transmission: int, *, omega, amplitude: float,
                          cycles: int = 6, output: str = "q_motor", **kw) -> FrequencyResponse:
    """Stepped-sine frequency response of one transmission: the first harmonic of the measured
    ``{output}_{i}`` (default the motor encoder, [rad]) over the commanded motor torque [N·m], from the
    second half of each run of :func:`stepped_sine` (``kw`` go there). Returns a FrequencyResponse whose
    ``runs`` are the SimRuns."""
    runs = stepped_sine(device, transmission, omega=omega, amplitude=amplitude, cycles=cycles, **kw)
    require_free(runs, "stepped sine")
    out, inp = f"{output}_{transmission}", f"torque_motor_cmd_{transmission}"
    omega = np.asarray(omega, float).ravel()
    ratio = [first_harmonic_ratio(r.log, out, inp, w) for r, w in zip(runs, omega)]
    unit = "rad/(N·m)" if output.startswith("q_") else "-"
    return FrequencyResponse(omega, ratio, output=out, input=inp, unit=unit, method="stepped_sine",
                             amplitude=float(amplitude), label=f"{compile_device(device).name}, {amplitude:g} N·m",
                             meta={"device": compile_device(device).name, "transmission": transmission,
                                   "cycles": cycles}, runs=runs)


def _active_limits(device):
    """Lower/upper limits [rad] of the active joints."""
    joints = compile_device(device).device.kinematics.joints
    act = [js for js in joints if getattr(js, "mu", None) in (None, 1) and getattr(js, "sigma", 0) != 2]
    return np.array([js.lower for js in act], float), np.array([js.upper for js in act], float)


def joint_friction_trajectory(device, weights, speeds, travel: float = 0.6, accel: float = 4.0, q0=None,
                              rate_hz: float = 10_000.0, control_hz: float | None = None, log_rate_hz: float = 1_000.0,
                              seed: int = 0, bandwidth_hz: float = 8.0, experiment: str = "joint_friction",
                              progress=None) -> SimRun:
    """Back-and-forth constant-velocity moves of a combination of active joints (joint-space PID).

    weights : per active joint (1-based) → speed multiplier, e.g. {2: 1, 3: 1} moves joints 2 and 3
        together; joints not listed are held still. speeds [rad/s], travel [rad] per stroke.
    This is how S2 §V-C builds t1 (q̇5 = q̇2), t2 (q̇5 = 0) and t3 (q̇2 = 0) on the CEA branch."""
    device = compile_device(device)   # built once: sim model, PID gains and log share it
    m = sim_model(device, rate_hz=rate_hz, control_hz=control_hz, stops=True)
    na = m.na
    lo, hi = _active_limits(device)
    q0 = 0.5 * (lo + hi) if q0 is None else np.asarray(q0, float)
    q_prof, qd_prof = constant_velocity_profile(np.asarray(speeds, float), travel, accel, m.dt)
    q_prof = q_prof - 0.5 * travel  # centre the strokes on q0
    ref_q = np.tile(q0, (q_prof.size, 1))
    ref_qd = np.zeros((q_prof.size, na))
    for j, w in weights.items():
        if not 1 <= j <= na:
            raise ValueError(f"active joint {j} does not exist ({na} active joints)")
        ref_q[:, j - 1] += w * q_prof
        ref_qd[:, j - 1] = w * qd_prof
    m.mode = _core.ControlMode.JointPID
    m.kp, m.kd, m.ki = pid_gains(m, device, q0, bandwidth_hz)
    m.velocity_cutoff_hz = 100.0
    opts = dict(weights={str(k): float(v) for k, v in weights.items()}, speeds=list(map(float, speeds)),
                travel=travel, accel=accel, q0=q0, rate_hz=rate_hz, control_hz=control_hz)
    ref_q[:, :] = np.clip(ref_q, lo, hi)
    return run_on_twin(device, m, ref_q[0], ref_q, ref_qd, np.zeros_like(ref_q), None, seed=seed,
                       experiment=experiment, options=opts, log_rate_hz=log_rate_hz, reference_space="joint",
                       progress=progress)


def cea_friction_trajectory(device, kind: str, speeds=(0.2, 0.4, 0.8), **kw) -> SimRun:
    """S2 friction tests on the CEA branch (active joints q1, q2, q5 = active indices 1, 2, 3):
    t1 — q̇5 = q̇2; t2 — q̇5 = 0; t3 — q̇2 = 0 (C34)."""
    weights = {"t1": {2: 1.0, 3: 1.0}, "t2": {2: 1.0}, "t3": {3: 1.0}}
    if kind not in weights:
        raise ValueError(f"kind must be t1, t2 or t3 (got {kind!r})")
    return joint_friction_trajectory(device, weights[kind], speeds, experiment=f"friction_{kind}", **kw)


def swept_sine(device: Device | CompiledDevice, transmission: int, amplitude: float, f0_hz: float = 1.0,
               f1_hz: float = 50.0, duration: float = 10.0, q0=None, rate_hz: float = 10_000.0, seed: int = 0,
               progress=None) -> SimRun:
    """Linear chirp of motor torque [N·m] from f0_hz to f1_hz [Hz] on one transmission, torque mode, links
    free (see :func:`swept_sine_response`)."""
    device = compile_device(device)
    f0, f1 = f0_hz, f1_hz
    m = sim_model(device, rate_hz=rate_hz, control_hz=rate_hz, stops=True)
    na = m.na
    _check_index(transmission, na, "transmission")
    q = torque_mode_start(device, m, q0)
    n = int(round(duration * rate_hz))
    t = np.arange(n) / rate_hz
    ff = np.zeros((n, na))
    ff[:, transmission - 1] = amplitude * np.sin(2 * np.pi * (f0 * t + 0.5 * (f1 - f0) / duration * t**2))
    m.mode = _core.ControlMode.Torque
    opts = dict(transmission=transmission, amplitude=amplitude, f0_hz=f0, f1_hz=f1, duration=duration, q0=q)
    return run_on_twin(device, m, q, np.tile(q, (n, 1)), np.zeros((n, na)), ff, None, seed=seed,
                       experiment="swept_sine", options=opts, log_rate_hz=rate_hz, progress=progress)


def swept_sine_response(device: Device | CompiledDevice, transmission: int, amplitude: float,
                        f0_hz: float = 1.0, f1_hz: float = 50.0, output: str = "q_motor", **kw) -> FrequencyResponse:
    """Swept-sine frequency response of one transmission: DFT of the measured ``{output}_{i}`` over the DFT
    of the commanded motor torque, on the bins strictly inside (f0_hz, f1_hz) (``kw`` go to
    :func:`swept_sine`). Returns a FrequencyResponse whose ``runs[0]`` is the SimRun."""
    run = swept_sine(device, transmission, amplitude, f0_hz=f0_hz, f1_hz=f1_hz, **kw)
    require_free([run], "swept sine")
    out, inp = f"{output}_{transmission}", f"torque_motor_cmd_{transmission}"
    y, u = np.asarray(run.log[out], float), np.asarray(run.log[inp], float)
    rate = run.log.meta["rate_hz"]
    f = np.fft.rfftfreq(u.size, 1.0 / rate)
    Y, U = np.fft.rfft(y - y.mean()), np.fft.rfft(u - u.mean())
    band = (f > f0_hz) & (f < f1_hz)
    unit = "rad/(N·m)" if output.startswith("q_") else "-"
    name = compile_device(device).name
    return FrequencyResponse(2 * math.pi * f[band], Y[band] / U[band], output=out, input=inp, unit=unit,
                             method="swept_sine", amplitude=float(amplitude), label=f"{name}, swept sine",
                             meta={"device": name, "transmission": transmission, "f0_hz": f0_hz, "f1_hz": f1_hz},
                             runs=[run])
