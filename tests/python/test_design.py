"""`tendyn design` (issue 32): the batch design space against independent routes, S1's conclusions C15/C16 on the
McGill twin, L-EXOS's shipped design against the front, the command's files and refusals, and a real Dask
scheduler."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tendyn.analysis.design_space import DesignSpace, read_motor_table
from tendyn.cli import main
from tendyn.device import load_device
from tendyn.pipelines.design import run_design

LEXOS_VARY = {"t1.motor_radius": (0.004, 0.02), "t2.driven_radius": (0.02, 0.08), "t4.reducer_ratio": (2.0, 16.0),
              "t3.motor_radius": (0.004, 0.02)}


def _load_text(text, tmp_path, name="d.toml"):
    p = tmp_path / name
    p.write_text(text)
    return load_device(p)


@pytest.fixture(scope="module")
def lexos_space():
    return DesignSpace("lexos", LEXOS_VARY, pose_budget=60)


def test_serial_quantities_match_the_handle_model_on_written_files(lexos_space, tmp_path):
    """Oracle: the handle maps' HandleModel (per design, per pose; friction from the core's statics of the written
    file, not the space's r_m scaling) on device files written from random designs."""
    from tendyn.analysis.handle_maps import HandleModel

    sp = lexos_space
    rng = np.random.default_rng(3)
    X = rng.uniform(sp.lower, sp.upper, (2, len(sp.names)))
    F = sp.evaluate(X)
    for d, x in enumerate(X):
        dev = _load_text(sp.device_text(x), tmp_path, f"d{d}.toml")
        hm = HandleModel(dev)
        mass, visc, dry, force, bmin = [], [], [], [], []
        peak = np.array([t.motor.peak_torque for t in dev.transmissions])
        for q in sp.serial.Q:
            _, Ur, Jr, _ = hm.task(q)
            pose = hm.at(q)
            mass.append(np.linalg.eigvalsh(pose.mass)[-1])
            ev = np.linalg.eigvalsh(pose.viscous)
            visc.append(ev[-1])
            bmin.append(ev[0])
            # the rotation Ur differs from the space's basis by signs only: the mean over ± axes is the same
            dirs = []
            for k in range(Jr.shape[0]):
                qd = hm.joint_velocity(q, np.eye(Jr.shape[0])[k], "mass")
                dirs.append(np.sum(hm.coulomb_motor * np.abs(hm.G @ qd)))
            dry.append(np.mean(dirs))
            rows = pose.rows
            force.append(np.min(peak / np.linalg.norm(rows, axis=1)))
        assert F["apparent_mass"][d] == pytest.approx(np.mean(mass), rel=1e-9)
        assert F["viscous_friction"][d] == pytest.approx(np.mean(visc), rel=1e-9)
        assert F["dry_friction"][d] == pytest.approx(np.mean(dry), rel=1e-9)
        assert F["peak_force"][d] == pytest.approx(np.min(force), rel=1e-9)
        assert F["zwidth"][d] == pytest.approx(2 * 1000.0 * np.min(bmin), rel=1e-9)


def test_bench_quantities_against_the_plant_and_the_ratio_study():
    """Oracles: the undamped poles of S1's state space (python-control), the bandwidth of the sympy-derived G
    (SensitivityStudy), and ratio_tradeoff's peak force and band torque (per r, through TendonDrivePlant)."""
    import control

    from tendyn.analysis.s1_plant import PlantParams, TendonDrivePlant, ratio_tradeoff, sensitivity_study

    motors = [{"name": "m", "rotor_inertia": 0.575 / 225, "continuous_torque": 0.02, "peak_torque": 0.05}]
    sp = DesignSpace("mcgill_bench", {"ratio": (2.0, 60.0), "k1": (1e3, 4.56e6)}, motors)
    r = np.array([5.0, 15.0, 40.0])
    X = np.column_stack([r, [1e3, 2.566e4, 4.56e6], np.zeros(3)])
    F = sp.evaluate(X)
    for i in range(3):
        p = PlantParams(r=r[i], I_M=0.575 / 225, B=0.0, k1=X[i, 1], k2=1e5, I_c=0.05, k_z=1e9)
        w = np.sort(np.abs(np.imag(control.poles(TendonDrivePlant(p).ss()))))
        assert F["resonance_hz"][i] == pytest.approx(w[w > 0][0] / (2 * math.pi), rel=1e-6)
        p = p.replace(B=10.8 / 225)
        study = sensitivity_study("k1", [X[i, 1]], p, omega=2 * math.pi * np.logspace(-2, 3, 600))
        assert F["bandwidth_hz"][i] == pytest.approx(study.bandwidth_hz()[0], rel=1e-12)
        assert F["sensitivity_k1"][i] == pytest.approx(study.max_abs()[0], rel=1e-9)
        tr = ratio_tradeoff(p, r=[r[i]], output_N=1.0, freq_hz=40.0, torque_max_Nm=0.05)
        assert F["peak_force"][i] == pytest.approx(tr.peak_force_N[0], rel=1e-9)
        assert F["band_force"][i] == pytest.approx(0.05 / tr.torque_Nm[0], rel=1e-9)


def test_C15_front_trades_rejection_against_saturation_and_backdriven_inertia():
    """C15 on the McGill twin: along the front over r, rejection and back-driven inertia both grow with r; the
    saturation bound (band_force ≥ 1 N at τ_max) caps r at ratio_tradeoff's r_saturation (independent route)."""
    from tendyn.analysis.s1_plant import PlantParams, ratio_tradeoff

    motors = [{"name": "m", "rotor_inertia": 0.575 / 225, "continuous_torque": 0.02, "peak_torque": 0.05}]
    sp = DesignSpace("mcgill_bench", {"ratio": (2.0, 60.0)}, motors)
    free = run_design(sp, ["apparent_mass", "rejection"], population=24, generations=25, islands=1)
    r = free.X[:, 0]
    o = np.argsort(r)
    mass, rej = free.F["apparent_mass"][o], free.F["rejection"][o]
    assert len(r) > 5 and np.all(np.diff(mass) >= 0) and np.all(np.diff(rej) >= 0)
    assert mass[-1] > 10 * mass[0] and rej[-1] > 10 * rej[0]
    capped = run_design(sp, ["apparent_mass", "rejection"], [("band_force", ">=", 0.5)], population=24,
                        generations=25, islands=1)
    study = ratio_tradeoff(PlantParams(), r=np.linspace(2, 60, 2901), output_N=0.5, freq_hz=40.0, torque_max_Nm=0.05)
    r_sat = study.r_saturation()                  # above it the band needs more than τ_max: saturation
    r_peak = 0.5 / 0.05                           # below it r τ_max |G(0)| < 0.5 N: not enough peak force
    assert math.isfinite(r_sat) and r.max() > r_sat and r.min() < r_peak
    rc = capped.X[:, 0]
    assert len(rc) > 3 and r_sat * 0.95 < rc.max() <= r_sat and r_peak <= rc.min() < 1.05 * r_peak


def test_C16_front_is_stiff_proximal_soft_distal():
    """C16 on the McGill twin: maximising the bandwidth while minimising |S_k1| puts every front design at the
    stiffest proximal section with a softer distal one, and the front widens the bandwidth of the shipped bench."""
    sp = DesignSpace("mcgill_bench", {"k1": (1e3, 4.56e6), "k2": (1e3, 1e6)})
    # 60 generations: at 30 the front was not converged and its stiffest-k1 edge moved with pymoo's version
    # (0.6.1 vs 0.6.2: a design at k1 = 0.71 of the bound); at 60 six seeds on both versions give k1 ≥ 0.91.
    res = run_design(sp, ["bandwidth_hz", "sensitivity_k1"], population=32, generations=60, islands=1)
    k1, k2 = res.X[:, 0], res.X[:, 1]
    assert np.all(k1 > 4 * k2) and np.median(k1) > 0.9 * 4.56e6 and np.all(k1 > 0.8 * 4.56e6)
    better = (res.F["bandwidth_hz"] > res.shipped["bandwidth_hz"]) & (res.F["sensitivity_k1"] < res.shipped["sensitivity_k1"])
    assert better.any() and not res.shipped_dominates_front()


def test_lexos_shipped_design_is_on_or_behind_the_front(lexos_space):
    res = run_design(lexos_space, ["apparent_mass", "dry_friction", "peak_force"], population=24, generations=15,
                     islands=1)
    assert len(res.X) > 3 and not res.shipped_dominates_front()
    best = res.best_improvement()
    assert all(v >= -1e-12 for v in best.values())
    assert "improvement over the shipped design" in res.table()


def test_cli_writes_loadable_device_files_and_a_report(tmp_path, capsys):
    motors = tmp_path / "motors.csv"
    motors.write_text("name,rotor_inertia,continuous_torque,peak_torque,torque_constant\n"
                      "small,2e-5,0.3,1.2,0.05\nbig,1e-4,1.2,5.0,0.2\n")
    out = tmp_path / "front"
    rc = main(["design", "lexos", "--vary", "t1.motor_radius=0.004:0.02", "--vary", "t4.reducer_ratio=2:16",
               "--objective", "apparent_mass", "--objective", "peak_force", "--motors", str(motors),
               "--population", "12", "--generations", "4", "--islands", "1", "--out", str(out), "--json"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert (out / "report.html").is_file() and (out / "design.json").is_file()
    first = out / doc["front"][0]["file"]
    dev = load_device(first)
    assert dev.transmissions[0].motor_radius == pytest.approx(doc["front"][0]["design"]["t1.motor_radius"])
    assert main(["routing", "show", str(first)]) == 0
    assert main(["maps", str(first), "--points", "3", "--json"]) == 0
    capsys.readouterr()


@pytest.mark.parametrize("argv, option", [
    (["--vary", "t9.motor_radius=0.004:0.02", "--objective", "apparent_mass"], "--vary"),
    (["--vary", "t1.motor_radius=0.02:0.004", "--objective", "apparent_mass"], "--vary"),
    (["--vary", "t1.motor_radius=-1:0.02", "--objective", "apparent_mass"], "--vary"),
    (["--vary", "t1.motor_radius=0.004:0.02", "--objective", "stiffness"], "--objective"),
    (["--vary", "t1.motor_radius=0.004:0.02", "--objective", "nope"], "--objective"),
    (["--vary", "t1.motor_radius=0.004:0.02", "--objective", "apparent_mass", "--constraint", "x>=1"], "--constraint"),
    (["--vary", "t1.motor_radius=0.004:0.02", "--objective", "apparent_mass", "--scheduler", "bogus"], "--scheduler"),
])
def test_cli_refuses_in_one_line(argv, option, tmp_path, capsys):
    try:
        rc = main(["design", "lexos", *argv, "--out", str(tmp_path / "o")])
    except SystemExit as exc:
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tendyn: error:") and option in err[0]
    assert not (tmp_path / "o").exists()


def test_motor_table_rejects_bad_rows(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("name,rotor_inertia,continuous_torque,peak_torque\na,1e-5,2,1\n")
    with pytest.raises(ValueError, match="continuous_torque > peak_torque"):
        read_motor_table(p)


def test_campaigns_on_a_real_scheduler_equal_in_process(dask_cluster):
    """`--scheduler tcp://HOST:PORT` on a real `dask scheduler` with two `dask worker` processes (> 5 s: the issue
    asks for real processes, and starting them costs seconds): the design islands give what this process gives."""
    sp = DesignSpace("mcgill_bench", {"k1": (1e3, 4.56e6), "k2": (1e3, 1e6)})
    kw = dict(population=12, generations=5, islands=3, seed=7)
    here = run_design(sp, ["bandwidth_hz", "sensitivity_k1"], **kw)
    there = run_design(sp, ["bandwidth_hz", "sensitivity_k1"], scheduler=dask_cluster, **kw)
    assert there.scheduler == dask_cluster
    np.testing.assert_array_equal(here.X, there.X)
    for k in here.F:
        np.testing.assert_array_equal(here.F[k], there.F[k])


@pytest.mark.slow
def test_sweep_and_identify_on_a_real_scheduler_equal_in_process(dask_cluster):
    """The same for a sweep and an identification campaign in batches (`pytest -m slow`: their fresh workers derive
    S1's plant and build the TX40 model, ~20 s; the same batching code runs in the fast suite on LocalClusters,
    test_s1.py::test_sweep_cli_on_a_local_dask_cluster and test_ident.py::test_campaign_on_a_dask_scheduler)."""
    from tendyn.devices import load
    from tendyn.pipelines.sweep import design_grid, evaluate_design, run_sweep

    bench = load("mcgill_bench")
    params = {"friction_c0": np.array([0.05, 0.15])}
    fields = {k: v for k, v in bench.to_dict().items() if k not in ("name", "description", "source")}
    res = run_sweep(bench, params, amplitudes=(2.0,), freqs_hz=[30.0], scheduler=dask_cluster,
                    progress=False)
    assert res.rows == [evaluate_design(fields, d, [2.0], [30.0]) for d in design_grid(params)]

    from tendyn.ident import IDIM
    from tendyn.ident.estimate import cached_model

    tx40 = load("tx40")
    logs = _tx40_logs(cached_model(tx40), 3)
    local = IDIM(tx40, cutoff_hz=20.0, decimate=10).fit(logs, crossval=False)
    remote = IDIM(tx40, cutoff_hz=20.0, decimate=10, scheduler=dask_cluster).fit(logs, crossval=False)
    np.testing.assert_array_equal(remote.params_, local.params_)


def _tx40_logs(model, n):
    """n short synthetic TX40 logs (test_ident's generator)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("_ti", Path(__file__).with_name("test_ident.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return [mod._synthetic_tx40(model, duration=2.0, noise=0.01, seed=s) for s in range(1, n + 1)]


@pytest.mark.parametrize("r", [1, 2, 3, 4])
def test_sym_extremes_against_eigvalsh(r):
    from tendyn.analysis.design_space import sym_extremes

    rng = np.random.default_rng(r)
    M = rng.normal(size=(50, r, r))
    S = M @ np.swapaxes(M, -1, -2)
    S[0] = np.eye(r) * 2.0                                    # repeated eigenvalues
    lo, hi = sym_extremes(S)
    ev = np.linalg.eigvalsh(S)
    np.testing.assert_allclose(lo, ev[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(hi, ev[:, -1], rtol=1e-9, atol=1e-9)


def test_local_cluster_workers_keep_their_heap_between_generations():
    """A worker of the local cluster evaluates one generation's batch after another without faulting its heap in
    again (issue 32: with glibc's start thresholds a fresh worker trimmed it after every batch, ~330 page faults
    per 64-design batch of L-EXOS's 81 poses and 72 000 per island of the benchmark, +20 % CPU against the warm
    in-process run; the cluster's MALLOC_* environment, :data:`tendyn.ident.cluster.QUIET_CONFIG`, removes them:
    without it this test measured 450–1 000 faults per batch, with it 0)."""
    import resource

    from dask.distributed import Client

    from tendyn.ident.cluster import local_cluster

    if not hasattr(resource, "RUSAGE_THREAD"):
        pytest.skip("per-thread page faults are Linux's (glibc reads the MALLOC_* environment)")
    space = DesignSpace("lexos", LEXOS_VARY)                 # the whole pose grid: batches of a few MB
    X = np.random.default_rng(0).uniform(space.lower, space.upper, (64, len(space.names)))

    def faults_per_batch(space, X, batches=20):
        import resource

        space.evaluate(X)                                    # the first batch maps the heap once
        f0 = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
        for _ in range(batches):
            space.evaluate(X)
        return (resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - f0) / batches

    with local_cluster(1) as cluster, Client(cluster) as client:
        faults = client.submit(faults_per_batch, space, X, pure=False).result()
    assert faults < 20, f"{faults:.0f} page faults per batch"
