"""Assemble the C++ simulator model of a device (tendyn._core.SimModel) from its compiled form.

The rigid body, the active-coordinate map and the transmission come from
:func:`tendyn.device.compile_device` (built once per device); this module only copies them into a new
``SimModel`` per run and sets the run's rates, friction and sensors.
"""

from __future__ import annotations

import numpy as np

from tendyn import _core
from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.sim.limits import CHAIN_RATE_HZ
from tendyn.transmission import Transmission


def default_control_hz(device: Device | CompiledDevice) -> float:
    """Controller rate [Hz]: 1 kHz for cable drives (S0's servo), 5 kHz for capstan drives, whose light
    rotors on the capstan spring need a faster collocated loop to damp the ~20 Hz link resonance."""
    return 5_000.0 if compile_device(device).device.drives else 1_000.0


STOP_PENETRATION = 0.02
"""End stops (sim.hpp, ``stop_stiffness``): depth [rad or m] to which the largest joint torque the motors can give
(peak torques through the transmission) pushes a joint past its limit; K_s = that torque / STOP_PENETRATION."""
STOP_DAMPING_RATIO = 0.7
"""End stops: damping ratio ζ of the stop on the largest actuated-joint inertia, B_s = 2 ζ √(K_s m)."""


def end_stops(compiled: CompiledDevice, m: _core.SimModel) -> None:
    """Set the twin's end stops (sim.hpp: a spring–damper past each tree joint's limit, active and passive) on a
    finalized model ``m``: the limits of the device file, K_s from :data:`STOP_PENETRATION` and the motors' peak
    torques, B_s from :data:`STOP_DAMPING_RATIO` and the largest diagonal entry of the actuated joints' inertia
    (links at the middle of the ranges, plus the rotors reflected through G_m)."""
    import pinocchio as pin

    from tendyn.device.rigid_body import tree_joint_numbers

    joints = compiled.device.kinematics.joints
    numbers = tree_joint_numbers(compiled.device)
    lo = np.array([-np.inf if joints[n - 1].lower is None else joints[n - 1].lower for n in numbers], float)
    hi = np.array([np.inf if joints[n - 1].upper is None else joints[n - 1].upper for n in numbers], float)
    L, c = (np.asarray(a, float) for a in compiled.active_map)
    Gm = np.asarray(m.Gm, float)
    joint_peak = np.abs(Gm).T @ np.asarray(m.peak_torque, float)[:Gm.shape[0]]
    torque = float(np.max(joint_peak)) if joint_peak.size and np.all(np.isfinite(joint_peak)) else 0.0
    if torque <= 0.0 or not np.any(np.isfinite(lo) | np.isfinite(hi)):
        return
    mid = np.where(np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), np.where(np.isfinite(lo), lo, hi))
    mid = np.where(np.isfinite(mid), mid, 0.0)
    qa = np.linalg.lstsq(L, mid - c, rcond=None)[0]
    pm = compiled.pinocchio_model
    Mt = pin.crba(pm, pm.createData(), L @ qa + c)
    Mt = np.triu(Mt) + np.triu(Mt, 1).T
    Ma = L.T @ Mt @ L + Gm.T @ np.diag(np.asarray(m.rotor_inertia, float)[:Gm.shape[0]]) @ Gm   # rotors reflected
    m.stop_lower, m.stop_upper = lo, hi
    m.stop_stiffness = torque / STOP_PENETRATION
    m.stop_damping = 2.0 * STOP_DAMPING_RATIO * float(np.sqrt(m.stop_stiffness * np.max(np.diag(Ma))))


def sim_model(device: Device | CompiledDevice, rate_hz: float = 10_000.0, control_hz: float | None = None,
              friction: bool = True, sensors: bool = True, stops: bool = False) -> _core.SimModel:
    """A new simulator model of ``device`` (a Device or its CompiledDevice; nothing is rebuilt).

    Parameters
    ----------
    rate_hz : integration rate [Hz] (1–20 kHz)
    control_hz : controller and sensor rate [Hz] (default: :func:`default_control_hz`); rate_hz must be
        a multiple of it
    friction : False switches every friction source off (energy checks, FRFs)
    sensors : False gives ideal sensors (no quantisation, no current noise)
    stops : True puts end stops at the device's joint limits (:func:`end_stops`, issue 40); the experiments
        (:mod:`tendyn.sim.experiments`: constant velocity, exciting, stepped and swept sines, friction
        trajectories) and the hand and wall runs of Fig. 7 / Z-width turn them on; the bare model (physics
        checks from arbitrary states) leaves them off
    """
    if not CHAIN_RATE_HZ[0] <= rate_hz <= CHAIN_RATE_HZ[1]:
        raise ValueError(f"rate_hz must be within 1–20 kHz (got {rate_hz})")
    if control_hz is None:
        control_hz = default_control_hz(device)
    decim = rate_hz / control_hz
    if abs(decim - round(decim)) > 1e-9 or round(decim) < 1:
        raise ValueError(f"rate_hz ({rate_hz}) must be a multiple of control_hz ({control_hz})")
    compiled = compile_device(device)
    device = compiled.device
    m = _core.SimModel()
    m.body = compiled.rigid_body          # copied into the SimModel
    m.L, m.c = compiled.active_map
    m.dt = 1.0 / rate_hz
    m.control_decimation = int(round(decim))
    drives = device.drives
    if getattr(device, "n_plus_one", False):   # N+1 tendons (sim.hpp, DriveKind::Tendons)
        tm = compiled.tendon_model
        m.drive = _core.DriveKind.Tendons
        m.tendons = tm if friction else _core.TendonModel(tm.K, tm.motor_radius, tm.tension_min, tm.last_joint)
        motors = [t.motor for t in device.transmissions]
        sens = [t.sensors for t in device.transmissions]
    elif device.transmissions:
        tr = compiled.transmission if friction else Transmission.from_device(device, losses=False)
        m.drive = _core.DriveKind.Tendon
        m.tendon = tr.model
        motors = [t.motor for t in device.transmissions]
        sens = [t.sensors for t in device.transmissions]
    elif drives:
        m.drive = _core.DriveKind.Elastic
        m.ratio = np.array([d.ratio for d in drives], float)
        m.stiffness_motor = np.array([d.stiffness_motor for d in drives], float)
        m.damping_motor = np.array([d.damping_motor for d in drives], float)
        if friction:
            m.coulomb_motor = np.array([d.coulomb_motor for d in drives], float)
            m.viscous_motor = np.array([d.viscous_motor for d in drives], float)
        m.offset_joint = np.array([d.offset_joint for d in drives], float)
        motors = [d.motor for d in drives]
        sens = [d.sensors for d in drives]
    else:
        raise ValueError(f"{device.name}: no transmissions or drives to simulate")
    m.rotor_inertia = np.array([mo.rotor_inertia for mo in motors], float)
    m.torque_constant = np.array([mo.torque_constant for mo in motors], float)
    m.peak_torque = np.array([mo.peak_torque for mo in motors], float)
    tables = compiled.terms.joint_tables() if getattr(device, "terms", ()) else None
    if tables is not None:             # [[terms]]: the twin's truth is the file's values
        m.term_lo, m.term_step, m.term_torque = tables
    if sensors:
        m.encoder_counts = np.array([s.encoder_counts for s in sens], float)
        m.current_noise = np.array([s.current_noise for s in sens], float)
    m.finalize()
    if stops:
        end_stops(compiled, m)
        m.finalize()          # checks the stops (sizes, lower <= upper, K_s, B_s >= 0)
    return m


LOG_FIELDS = ("time", "q_motor_meas", "torque_motor_meas", "torque_motor_cmd", "q_joint", "qd_joint", "q_motor",
              "qd_motor")
"""The channels :func:`tendyn._core.run` writes, in the order of the C++ ``SimLog`` fields."""


def run_log(model: _core.SimModel, data: _core.SimData, ref_q, ref_v, ff, torque_ext, log_every: int) -> dict:
    """Run ``len(ref_q)`` steps of the simulator and return its log as a dict of arrays.

    Parameters
    ----------
    ref_q, ref_v : (steps, model.n_ref) references [rad, rad/s] (joints; motors in MotorPID mode)
    ff : (steps, model.n_ff) feedforward: motor torques [N·m] (joint torques [N·m] in JointPID mode)
    torque_ext : (steps, na) external joint torques [N·m]. For a square device n_ref = n_ff = na; N+1 has
        nm = na + 1 motors.
    log_every : log one row every this many steps (a multiple of ``model.control_decimation``)

    Returns
    -------
    dict
        ``time`` (rows,) [s] and ``q_motor_meas``, ``torque_motor_meas``, ``torque_motor_cmd``, ``q_joint``,
        ``qd_joint``, ``q_motor``, ``qd_motor`` (rows, nm) (``q_joint``, ``qd_joint`` (rows, na)),
        rows = ceil(steps / log_every).
    """
    arrays = [np.ascontiguousarray(np.asarray(a, dtype=float)) for a in (ref_q, ref_v, ff, torque_ext)]
    steps, na = arrays[0].shape[0], model.na
    if int(log_every) < 1:
        raise ValueError(f"log_every must be >= 1 (got {log_every})")
    rows = (steps + int(log_every) - 1) // int(log_every)
    out = {"time": np.empty(rows)}
    for name in LOG_FIELDS[1:]:
        out[name] = np.empty((rows, na if name in ("q_joint", "qd_joint") else model.nm))
    _core.run(model, data, *arrays, int(log_every), *(out[k] for k in LOG_FIELDS))
    return out


def run_batch(models, datas, ref_q, ref_v, ff, torque_ext, log_every: int, threads: int = 0) -> dict:
    """Many independent runs at once (design sweep, Monte Carlo over parameters): C++ ``tendyn::run_batch``.

    Each run is stepped by the same allocation-free loop as :func:`run_log`, on its own ``SimData``; the runs
    are spread over ``threads`` worker threads (0: one per hardware thread) with the GIL released. A run's
    result does not depend on the thread that ran it: the batch equals the runs one after the other, bit for
    bit.

    Parameters
    ----------
    models : one ``SimModel`` for every run, or a sequence of one per run (same number of joints)
    datas : sequence of ``SimData``, one per run (distinct objects), each made for its run's model
    ref_q, ref_v, ff, torque_ext : (steps, na) shared by every run, or (runs, steps, na) one per run
        [rad, rad/s, N·m, N·m], as for :func:`run_log`
    log_every : log one row every this many steps (a multiple of every model's ``control_decimation``)
    threads : worker threads (0 = one per hardware thread; never more than the runs)

    Returns
    -------
    dict
        the channels of :func:`run_log` with a leading run axis: ``time`` (runs, rows), the others
        (runs, rows, na); and ``threads``, the number of threads used.
    """
    datas = list(datas)
    models = [models] if isinstance(models, _core.SimModel) else list(models)
    runs = len(datas)
    if runs == 0:
        raise ValueError("run_batch: no runs (datas is empty)")
    na = models[0].na
    arrays = []
    for a in (ref_q, ref_v, ff, torque_ext):
        a = np.asarray(a, dtype=float)
        if a.ndim == 2:
            a = a[None]
        if a.ndim != 3 or a.shape[0] not in (1, runs) or a.shape[2] != na:
            raise ValueError(f"run_batch: inputs must be (steps, {na}) or ({runs}, steps, {na}) (got {a.shape})")
        arrays.append(np.ascontiguousarray(a))
    steps = arrays[0].shape[1]
    if int(log_every) < 1:
        raise ValueError(f"log_every must be >= 1 (got {log_every})")
    rows = (steps + int(log_every) - 1) // int(log_every)
    out = {"time": np.empty((runs, rows))}
    for name in LOG_FIELDS[1:]:
        out[name] = np.empty((runs, rows, na))
    out["threads"] = _core.run_batch(models, datas, *arrays, int(log_every), int(threads),
                                     *(out[k] for k in LOG_FIELDS))
    return out
