"""`make bench`: the L-EXOS simulator against MuJoCo on the same physics (benchmarks/mujoco_lexos.py).

Protocol (lexos_sim_step_*):
1. The test: the twin at 10 kHz from q0 = (0.2, −0.8, 0.2, 0.6) rad, at rest, motor torques commanded
   open loop = the lossless gravity compensation at q0 + 0.02 N·m sines (0.7, 1.1, 1.3, 1.7 Hz) on every
   motor, held at the 1 kHz control rate. The arm creeps and sticks: every joint alternates stick and slip
   (the friction solver's hard case), for 2 s.
2. MuJoCo's frictionloss bounds are constants, the twin's depend on the tension (S0 eqs. 10–12): the MuJoCo
   model takes the twin's bounds averaged over the test (its operating point).
3. Agreement before timing, at t = 2 s, against the twin with the same constant bounds
   (mujoco_lexos.constant_bound_twin):
   * MuJoCo with converged settings (its defaults): within one motor-encoder count seen at each joint
     (2π / counts · r_m / K_jj: 9.6e-6 rad on joints 1–2): the two models are the same physics and the same
     time stepping, and no sensor of the device could tell them apart. Refused (no timing) otherwise.
   * each tuned setting: within 10 % of what the tension dependence changes in the twin (full twin vs
     constant-bound twin at 2 s, measured in the same run): a solver stopped early may err, but by much less
     than what MuJoCo's friction model leaves out anyway. Settings outside it are not used.
   The difference between the full twin and MuJoCo is reported (it is what MuJoCo cannot express).
4. Timing: tendyn (full twin, and the constant-bound twin) and every MuJoCo setting interleaved in one
   process, in a shuffled order each round, ROUNDS rounds of the 2 s run; thread CPU time
   (time.thread_time_ns) of tendyn._core.run (log every 10 steps) and of mujoco.rollout (one trajectory,
   preallocated outputs, the calling thread); the value is the median of the rounds, per step.
   The tuned baseline is the fastest tuned setting that passed its check.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import mujoco_lexos as ml

RATE_HZ = 10_000.0
SECONDS = 2.0
ROUNDS = 9
Q0 = np.array([0.2, -0.8, 0.2, 0.6])
SINE_HZ = (0.7, 1.1, 1.3, 1.7)
SINE_NM = 0.02


def test_inputs(compiled, model, steps: int):
    """Motor torques of the test (steps, na) [N·m]: gravity compensation at Q0 (lossless) + sines."""
    from tendyn import _core

    rd = _core.RigidBodyData(compiled.rigid_body)
    _core.gravity_torque(compiled.rigid_body, rd, Q0)
    hold = np.array(model.tendon.motor_from_joint_torque) @ np.array(rd.gravity_torque)
    t = np.arange(steps) / RATE_HZ
    return np.ascontiguousarray(hold + np.column_stack([SINE_NM * np.sin(2 * np.pi * f * t) for f in SINE_HZ]))


def held(ff: np.ndarray, decimation: int) -> np.ndarray:
    """The torques the twin applies at each step: ff sampled at its control steps and held."""
    return np.ascontiguousarray(ff[(np.arange(ff.shape[0]) // decimation) * decimation])


class TendynRunner:
    """tendyn._core.run of one model over fixed inputs, with preallocated log arrays (log every 10 steps)."""

    def __init__(self, model, ff: np.ndarray):
        from tendyn import _core

        self._core, self.model = _core, model
        self.data = _core.SimData(model)
        self.ff = ff
        self.zero = np.zeros_like(ff)
        self.log_every = model.control_decimation
        rows = (ff.shape[0] + self.log_every - 1) // self.log_every
        self.logs = [np.empty(rows)] + [np.empty((rows, model.na)) for _ in range(7)]

    def run(self) -> np.ndarray:
        self.data.reset(Q0, 1)
        z = self.zero
        self._core.run(self.model, self.data, z, z, self.ff, z, self.log_every, *self.logs)
        return np.array(self.data.q)


def thread_ns(f) -> int:
    t0 = time.thread_time_ns()
    f()
    return time.thread_time_ns() - t0


def encoder_count_at_joint(device) -> np.ndarray:
    """One motor-encoder count seen at each driven joint [rad]: 2π/counts · r_m / K_jj."""
    arr = device.routing_arrays()
    counts = np.array([t.sensors.encoder_counts for t in device.transmissions], float)
    return 2 * np.pi / counts * arr["motor_radius"] / np.diag(arr["K"])


def describe(opts: dict, disable: tuple) -> str:
    s = ", ".join(f"{k}={v}" for k, v in opts.items()) or "defaults (Newton, 100 iterations, tolerance 1e-8)"
    return s + (f"; disabled: {', '.join(disable)}" if disable else "")


def bench_simulator(results: list) -> dict:
    """The step against MuJoCo (entries lexos_sim_step_10kHz, lexos_sim_step_vs_mujoco_default,
    lexos_sim_step_vs_mujoco_no_friction, lexos_sim_realtime_factor). Returns what bench_batch reuses."""
    import mujoco

    from tendyn.device import compile_device, load_device
    from tendyn.devices import bundled
    from tendyn.sim.model import sim_model

    dev = load_device(bundled("lexos"))
    compiled = compile_device(dev)
    h = 1.0 / RATE_HZ
    steps = int(round(SECONDS * RATE_HZ))
    full = sim_model(compiled, rate_hz=RATE_HZ)
    ff = test_inputs(compiled, full, steps)
    ctrl = held(ff, full.control_decimation)[None]
    print("[bench] simulator: the twin's friction bounds at the operating point …", file=sys.stderr)
    pgs: dict = {}
    B, J = ml.operating_point_bounds(full, Q0, ff, stats=pgs)
    const = ml.constant_bound_twin(compiled, RATE_HZ, B, J)
    tw_full, tw_const = TendynRunner(full, ff), TendynRunner(const, ff)
    q_full, q_const = tw_full.run(), tw_const.run()

    settings = {"default": ({}, ())}
    for k, opts in enumerate(ml.TUNED_CANDIDATES):
        settings[f"tuned{k}"] = (opts, ml.TUNED_DISABLE)
    mj = {name: ml.MujocoRunner(ml.lexos_mjcf(dev, h, B, J, options=o, disable=dis), Q0, steps)
          for name, (o, dis) in settings.items()}
    mj["no_friction"] = ml.MujocoRunner(ml.lexos_mjcf(dev, h, B, J, options=ml.TUNED_CANDIDATES[0],
                                                      disable=ml.TUNED_DISABLE, friction=False), Q0, steps)
    count = encoder_count_at_joint(dev)
    tension_effect = np.abs(q_full - q_const)
    tuned_bound = 0.1 * tension_effect.max()
    agreement = {}
    for name, r in mj.items():
        if name == "no_friction":
            continue
        q = r.qpos(r.run(ctrl))[0, -1]
        agreement[name] = np.abs(q - q_const)
    if not np.all(agreement["default"] <= count):
        raise SystemExit(f"[bench] MuJoCo (defaults) and the constant-bound twin disagree at 2 s: "
                         f"|Δq| = {agreement['default']} rad > one encoder count {count}: not the same physics")
    passed = [n for n in settings if n != "default" and agreement[n].max() <= tuned_bound]
    if not passed:
        raise SystemExit(f"[bench] no tuned MuJoCo setting within {tuned_bound:.3g} rad of the twin at 2 s")
    q_mj_default = mj["default"].qpos(mj["default"].state)[0, -1]

    print(f"[bench] simulator: tendyn and MuJoCo interleaved, {ROUNDS} rounds of {steps} steps …", file=sys.stderr)
    runners = {"tendyn": tw_full.run, "tendyn_constant_bounds": tw_const.run}
    runners.update({name: (lambda r=r: r.run(ctrl)) for name, r in mj.items()})
    times = {name: [] for name in runners}
    order = list(runners)
    rng = np.random.default_rng(0)
    for _ in range(ROUNDS):
        rng.shuffle(order)
        for name in order:
            times[name].append(thread_ns(runners[name]) / steps / 1e3)  # µs/step
    med = {name: float(np.median(v)) for name, v in times.items()}
    tuned = min(passed, key=lambda n: med[n])
    t_opts, t_dis = settings[tuned]
    version = mujoco.__version__
    model_text = (f"MuJoCo {version} mujoco.rollout, equal-physics L-EXOS (4 motor tendons with rotor armature, "
                  f"10 branch tendons with frictionloss + damping nu, 3 reducer joint frictionlosses; implicitfast, "
                  f"{RATE_HZ / 1e3:g} kHz; constant friction bounds at the operating point)")
    common = dict(
        protocol="benchmarks/sim_bench.py docstring", rounds=ROUNDS, steps_per_round=steps,
        timer="thread CPU time, median of rounds, interleaved",
        tendyn_all_rounds_us=times["tendyn"],
        tendyn_constant_bounds_us_per_step=med["tendyn_constant_bounds"],
        tendyn_friction_solver_iterations_per_step=pgs,
        tendyn_solver=f"exact finish {'on' if full.pgs_exact_finish else 'off'} (projection for the warm start's "
                      f"classification, active-set changes, Coulomb's law checked to {full.pgs_speed_tolerance:g} "
                      f"rad/s), else PGS (SOR {full.pgs_relaxation}), tolerance {full.pgs_tolerance:g} relative, "
                      f"at most {full.pgs_max_iterations} iterations (the twin's defaults)",
        mujoco_us_per_step={name: med[name] for name in mj},
        mujoco_settings={name: describe(*settings[name]) for name in settings} | {
            "no_friction": describe(*settings["tuned0"]) + ", frictionloss"},
        agreement_at_2s_rad={
            "bound_default_rad (one encoder count per joint)": count.tolist(),
            "bound_tuned_rad (10 % of the tension effect)": tuned_bound,
            "mujoco_vs_constant_bound_twin": {n: a.tolist() for n, a in agreement.items()},
            "tuned_settings_within_bound": passed,
            "full_twin_vs_constant_bound_twin (what MuJoCo cannot express)": tension_effect.tolist(),
            "full_twin_vs_mujoco_default": np.abs(q_full - q_mj_default).tolist(),
        },
        operating_point_bounds={"branch_N": B.tolist(), "reducer_Nm": J.tolist()},
        note="MuJoCo's frictionloss bounds cannot depend on tension: its model takes the twin's bounds at the "
             "operating point; the agreement is checked against the twin with those constant bounds.",
    )
    results.append(dict(name="lexos_sim_step_10kHz", value=med["tendyn"], unit="us/step",
                        baseline=f"{model_text}; tuned: {describe(t_opts, t_dis)}",
                        baseline_value=med[tuned], ratio=med[tuned] / med["tendyn"], **common))
    results.append(dict(name="lexos_sim_step_vs_mujoco_default", value=med["tendyn"], unit="us/step",
                        baseline=f"{model_text}; MuJoCo default solver settings",
                        baseline_value=med["default"], ratio=med["default"] / med["tendyn"]))
    results.append(dict(name="lexos_sim_step_vs_mujoco_no_friction", value=med["tendyn"], unit="us/step",
                        baseline=f"{model_text}; friction disabled (the floor of MuJoCo's fixed cost per step)",
                        baseline_value=med["no_friction"], ratio=med["no_friction"] / med["tendyn"]))
    results.append(dict(name="lexos_sim_realtime_factor", value=1e6 / RATE_HZ / med["tendyn"],
                        unit="sim s/CPU s", baseline=f"{model_text}; tuned: {describe(t_opts, t_dis)}",
                        baseline_value=1e6 / RATE_HZ / med[tuned], ratio=med[tuned] / med["tendyn"]))
    return dict(device=dev, compiled=compiled, bounds=(B, J), tuned=settings[tuned])


def bench_batch(results: list, setup: dict, runs: int = 16, seconds: float = 1.0, rounds: int = 5) -> None:
    """Monte Carlo over the friction: `runs` draws of the twin (every branch's τ0 and β scaled by a factor
    drawn in [0.7, 1.3]), each run `seconds` of the test. tendyn.sim.model.run_batch (one thread per core)
    against the same runs one after the other in tendyn, and against mujoco.rollout of the equal-physics
    models (the same draws, tuned settings) with nthread = the cores. Wall time (the batch is parallel),
    median of `rounds` interleaved rounds; the machine is shared, so the parallel speed-up is a lower bound."""
    import os

    from tendyn import _core
    from tendyn.sim.model import run_batch, run_log, sim_model

    dev, compiled = setup["device"], setup["compiled"]
    B, J = setup["bounds"]
    t_opts, t_dis = setup["tuned"]
    cores = os.cpu_count() or 1
    steps = int(round(seconds * RATE_HZ))
    rng = np.random.default_rng(11)
    scales = rng.uniform(0.7, 1.3, size=runs)
    models = []
    for s in scales:
        m = sim_model(compiled, rate_hz=RATE_HZ)
        models.append(ml.with_transmission(m, tau0=s * np.array(m.tendon.tau0), beta=s * np.array(m.tendon.beta)))
    ff = test_inputs(compiled, models[0], steps)
    z = np.zeros_like(ff)
    datas = [_core.SimData(m) for m in models]
    h = 1.0 / RATE_HZ
    mj_models = [ml.MujocoRunner(ml.lexos_mjcf(dev, h, s * B, s * J, options=t_opts, disable=t_dis), Q0, steps)
                 for s in scales]
    import mujoco
    from mujoco import rollout

    mjm = [r.model for r in mj_models]
    init = np.ascontiguousarray(np.broadcast_to(mj_models[0].state0, (runs, mj_models[0].state0.size)))
    ctrl = np.ascontiguousarray(np.broadcast_to(held(ff, models[0].control_decimation), (runs, steps, 4)))
    state = np.zeros((runs, steps, mj_models[0].state0.size))
    sens = np.zeros((runs, steps, 0))
    mj_datas = {n: [mujoco.MjData(mjm[0]) for _ in range(n)] for n in {1, cores}}

    def sequential():
        for m, d in zip(models, datas):
            d.reset(Q0, 1)
            run_log(m, d, z, z, ff, z, m.control_decimation)

    def batch():
        for d in datas:
            d.reset(Q0, 1)
        run_batch(models, datas, z, z, ff, z, models[0].control_decimation, threads=cores)

    def mj_roll(n):
        def go():
            rollout.rollout(mjm, mj_datas[n], init, ctrl, state=state, sensordata=sens)
        return go

    # the batch is the sequential runs, bit for bit
    sequential()
    q_seq = [np.array(d.q) for d in datas]
    batch()
    if not all(np.array_equal(a, np.array(d.q)) for a, d in zip(q_seq, datas)):
        raise SystemExit("[bench] run_batch differs from the sequential runs")
    print(f"[bench] batch: {runs} runs x {steps} steps, tendyn and MuJoCo, {rounds} rounds …", file=sys.stderr)
    runners = {"sequential": sequential, "batch": batch, "mujoco_1": mj_roll(1), f"mujoco_{cores}": mj_roll(cores)}
    wall = {k: [] for k in runners}
    cpu = {k: [] for k in runners}
    for _ in range(rounds):
        for k, f in runners.items():
            w, c = time.perf_counter(), time.process_time()
            f()
            wall[k].append(time.perf_counter() - w)
            cpu[k].append(time.process_time() - c)
    mw = {k: float(np.median(v)) for k, v in wall.items()}
    mc = {k: float(np.median(v)) for k, v in cpu.items()}
    extra = dict(runs=runs, steps_per_run=steps, threads=cores, timer="wall clock, median of rounds",
                 wall_s=mw, process_cpu_s=mc, load_average=os.getloadavg()[0],
                 draws="tau0 and beta of every branch scaled by U(0.7, 1.3)")
    results.append(dict(name="lexos_sim_batch", value=mw["batch"], unit="s",
                        baseline=f"the same {runs} runs one after the other (tendyn, one thread)",
                        baseline_value=mw["sequential"], ratio=mw["sequential"] / mw["batch"], **extra))
    results.append(dict(name="lexos_sim_batch", value=mw["batch"], unit="s",
                        baseline=f"mujoco.rollout nthread={cores}, the same draws on the equal-physics model, "
                                 f"tuned: {describe(t_opts, t_dis)}",
                        baseline_value=mw[f"mujoco_{cores}"], ratio=mw[f"mujoco_{cores}"] / mw["batch"]))
