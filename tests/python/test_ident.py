"""Identification (issue 9): treatment, regressor, base parameters, estimation, the real TX40, import, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.ident import (IDIM, AlignmentError, IdentModel, butter_zero_phase, khalil_from_pinocchio,
                          pinocchio_from_khalil)
from tendyn.ident.treatment import Treatment, stack_blocks, treat
from tendyn.io import make_log

ROOT = Path(__file__).resolve().parents[2]
TX40_DATA = ROOT / "python" / "tendyn" / "data" / "tx40"   # shipped, the same bytes as ../shared/external-data
TX40_MAP = TX40_DATA / "import.toml"


@pytest.fixture(scope="module")
def tx40():
    return IdentModel(load_device(bundled("tx40")))


# -- device file ---------------------------------------------------------------------------------------

def test_tx40_actuation_matrix():
    dev = load_device(bundled("tx40"))
    G = dev.motor_joint_matrix()
    expect = np.diag([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
    expect[5, 4] = 32.0                                     # q_m6 = 32 (q6 + q5)
    np.testing.assert_array_equal(G, expect)
    qm = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    q = np.linalg.solve(G, qm)
    assert q[5] == pytest.approx(qm[5] / 32 - q[4])        # PROVENANCE: q6 = q_m6/32 - q5
    np.testing.assert_allclose(dev.joint_offsets(), [0, -np.pi / 2, np.pi / 2, 0, 0, 0])
    y = np.ones(6)
    tau = y @ G
    assert tau[4] == pytest.approx(45 + 32)                 # tau5 = 45 y5 + 32 y6


def test_actuator_errors(tmp_path):
    from tendyn.device import DeviceError

    text = bundled("tx40").read_text().replace('coupling = { "5" = 1.0 }', 'coupling = { "6" = 1.0 }')
    (tmp_path / "tx40.urdf").write_text(bundled("tx40").with_suffix(".urdf").read_text())
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(DeviceError, match=r"actuators\[6\]\.coupling\.6: the motor's own joint"):
        load_device(p)
    p.write_text(bundled("tx40").read_text().replace("ratio = 45.0                          # [SEED]\n"
                                                     "encoder_offset", "ratoi = 45.0\nencoder_offset", 1))
    with pytest.raises(DeviceError, match=r"actuators\[3\]\.ratoi: unknown field \(did you mean 'ratio'\?\)"):
        load_device(p)


# -- treatment -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("rate_hz, cutoff_hz", [(1000.0, 20.0), (5000.0, 50.0)])
def test_butterworth_is_minus_3db_at_cutoff(rate_hz, cutoff_hz):
    t = np.arange(int(40 * rate_hz / cutoff_hz) + 4000) / rate_hz
    for f, expect_db in ((cutoff_hz, -3.0103), (cutoff_hz / 10, 0.0)):
        y = butter_zero_phase(np.sin(2 * np.pi * f * t), cutoff_hz, rate_hz)
        mid = slice(t.size // 4, 3 * t.size // 4)
        gain_db = 20 * np.log10(np.max(np.abs(y[mid])))
        assert gain_db == pytest.approx(expect_db, abs=0.05)


def test_sigma2_uses_the_squared_norm(claims_ctx):
    """C29: σ̂² = ‖Y − W x̂‖² / (r − b) and σ(x̂) from σ̂² (WᵀW)⁻¹, on data with a known noise level."""
    from tendyn.claims import assert_claim

    assert_claim("C29", claims_ctx)


# -- regressor -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["tx40", "cea_branch"])
def test_regressor_matches_pinocchio_per_sample(name):
    import pinocchio as pin

    m = IdentModel(load_device(bundled(name)))
    rng = np.random.default_rng(1)
    n, na = 7, m.n_active
    Q, V, A = rng.uniform(-2, 2, (n, na)), rng.normal(size=(n, na)), rng.normal(size=(n, na))
    W = m.regressor(Q, V, A)                                 # C++, all samples, standard columns
    model = pin.buildModelFromUrdf(str(m.device.kinematics.urdf)) if name == "tx40" else m.compiled.pinocchio_model
    model.gravity.linear = np.asarray(m.device.kinematics.gravity, float)
    data = model.createData()
    G = m.G
    for s in range(n):
        qt, vt, at = m.L @ Q[s] + m.c, m.L @ V[s], m.L @ A[s]
        Yp = m.L.T @ pin.computeJointTorqueRegressor(model, data, qt, vt, at)   # Pinocchio order
        Yk = khalil_from_pinocchio(Yp)
        for k, col in enumerate(m.standard_names):
            stem = col.rstrip("0123456789")
            num = int(col[len(stem):])
            if stem in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M"):
                link = m.tree_numbers.index(num)
                ref = Yk[:, 10 * link + ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M").index(stem)]
            else:
                j = m.active_numbers.index(num)
                ref = np.zeros(na)
                if stem in ("IA", "FV", "FS", "OFFSET"):
                    ref[j] = {"IA": A[s, j], "FV": V[s, j], "FS": np.sign(V[s, j]), "OFFSET": 1.0}[stem]
                else:
                    i = m.motor_joints.index(num)
                    g = G[i]
                    ref = g * {"IAm": g @ A[s], "FVm": g @ V[s], "FSm": np.sign(g @ V[s])}[stem]
            np.testing.assert_allclose(W[s::n, k], ref, atol=1e-10, rtol=0, err_msg=f"{name} {col} sample {s}")


@pytest.mark.parametrize("name", ["tx40", "cea_branch"])
def test_regressor_on_threads_is_bit_identical_to_one_thread(name):
    """The output ranges split over threads (each its own Pinocchio data, input samples shared at the seams
    computed twice) give the one-thread result bit for bit, filtered and decimated, serial and closed-loop."""
    from tendyn.ident.treatment import parallel_filter_taps

    m = IdentModel(load_device(bundled(name)))
    rng = np.random.default_rng(4)
    n, na = 5003, m.n_active
    Q, V, A = rng.uniform(-1, 1, (n, na)), rng.normal(size=(n, na)), rng.normal(size=(n, na))
    taps = parallel_filter_taps(5)
    one = m.regressor(Q, V, A, taps, 5, threads=1)
    assert np.count_nonzero(one) > one.size // 4
    for t in (2, 3, 7):
        np.testing.assert_array_equal(m.regressor(Q, V, A, taps, 5, threads=t), one)


def test_khalil_pinocchio_order_round_trip():
    import pinocchio as pin

    # independent route: Pinocchio's own dynamic parameters of a known inertia vs Khalil's definition
    m, c = 2.0, np.array([0.1, -0.2, 0.3])
    Ic = np.array([[0.5, 0.01, 0.02], [0.01, 0.6, 0.03], [0.02, 0.03, 0.7]])
    J = Ic + m * (c @ c * np.eye(3) - np.outer(c, c))           # about the frame origin
    khalil = [J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2], *(m * c), m]
    pin_order = pin.Inertia(m, c, Ic).toDynamicParameters()
    np.testing.assert_allclose(khalil_from_pinocchio(np.tile(pin_order, 2)), np.tile(khalil, 2), atol=1e-14)
    np.testing.assert_allclose(pinocchio_from_khalil(np.array(khalil)), pin_order, atol=1e-14)


def test_base_parameters_reproduce_the_standard_torque(tx40):
    import pinocchio as pin

    m = tx40
    rng = np.random.default_rng(5)
    n = 20
    Q, V, A = rng.uniform(-2, 2, (n, 6)), rng.normal(size=(n, 6)), rng.normal(size=(n, 6))
    x_std = m.prior() + rng.normal(scale=0.01, size=len(m.standard_names))   # any standard vector
    W = m.regressor(Q, V, A)
    base = m.base
    tau_base = W[:, list(base.columns)] @ (base.combination @ x_std)
    np.testing.assert_allclose(tau_base, W @ x_std, atol=1e-9)
    # independent route for the rigid-body part: Pinocchio's RNEA on the prior inertias
    rb_cols = [k for k, nme in enumerate(m.standard_names) if nme.rstrip("0123456789") in
               ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")]
    model = m.compiled.pinocchio_model
    data = model.createData()
    tau_rnea = np.concatenate([[pin.rnea(model, data, Q[s], V[s], A[s])[j] for s in range(n)] for j in range(6)])
    x_rb = np.zeros_like(x_std)
    x_rb[rb_cols] = m.prior()[rb_cols]
    np.testing.assert_allclose(W[:, list(base.columns)] @ (base.combination @ x_rb), tau_rnea, atol=1e-9)
    assert "ZZ1R" in base.names and base.rank == len(base.names)


# -- a synthetic TX40 log (the test makes it; no twin truth reaches the estimator) -----------------------

def _synthetic_tx40(m, rate_hz=1000.0, duration=8.0, noise=0.0, seed=0):
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * rate_hz)) / rate_hz
    q = np.zeros((t.size, 6)); qd = np.zeros_like(q); qdd = np.zeros_like(q)
    for j in range(6):
        for k in range(1, 4):
            a, f, ph = rng.uniform(0.1, 0.4) / k, 0.15 * k * (1 + 0.3 * j), rng.uniform(0, 2 * np.pi)
            w = 2 * np.pi * f
            q[:, j] += a * np.sin(w * t + ph); qd[:, j] += a * w * np.cos(w * t + ph)
            qdd[:, j] -= a * w * w * np.sin(w * t + ph)
    model = m.compiled.pinocchio_model
    data = model.createData()
    tau = np.array([pin.rnea(model, data, q[s], qd[s], qdd[s]) for s in range(t.size)])
    fv, fs = np.array([8.0, 6.0, 3.0, 1.0, 1.5, 0.8]), np.array([5.0, 4.0, 2.5, 0.8, 1.0, 0.5])
    tau += fv * qd + fs * np.tanh(qd / 1e-3)
    G = m.G
    qm = (q - m.joint_offsets) @ G.T
    y = np.linalg.solve(G.T, tau.T).T + noise * rng.normal(size=tau.shape)
    cols = {"time": t}
    cols.update({f"q_motor_{i + 1}": qm[:, i] for i in range(6)})
    cols.update({f"torque_motor_{i + 1}": y[:, i] for i in range(6)})
    return make_log(cols, device="tx40", rate_hz=rate_hz, seed=seed, experiment="exciting")


def test_noise_free_fit_and_one_sample_misalignment_is_caught(tx40):
    log = _synthetic_tx40(tx40)
    est = IDIM(tx40.device, cutoff_hz=20.0, decimate=10).fit(log, crossval=False)
    assert est.result_.residual_rel < 5e-3
    names = est.names_
    for j in range(1, 7):
        assert est.params_[names.index(f"FV{j}")] > 0
    # the blocks of one treated log hold the same samples; one block shifted by one sample is caught
    time, q, tau = tx40.joint_signals(log)
    tr = Treatment(20.0, 4, 10, 0.0, 1000.0, 10.0)
    blocks = treat(tx40, time, q, tau, tr)
    Y, W, rows = stack_blocks(blocks)
    b = blocks[2]
    b.time, b.y, b.W = b.time[1:], b.y[1:], b.W[1:]
    blocks[2] = b
    with pytest.raises(AlignmentError, match="joint block 3"):
        stack_blocks(blocks)
    blocks = treat(tx40, time, q, tau, tr)
    blocks[2].time = blocks[2].time + (blocks[2].time[1] - blocks[2].time[0])
    with pytest.raises(AlignmentError, match="joint block 3 is shifted by 1 samples"):
        stack_blocks(blocks)
    # and the data themselves: torques one decimated sample late against W make the exact fit inexact
    blocks = treat(tx40, time, q, tau, tr)
    Y, W, rows = stack_blocks(blocks)
    Wb = W[:, list(tx40.base.columns)]
    x, *_ = np.linalg.lstsq(Wb, Y, rcond=None)
    r_ok = np.linalg.norm(Y - Wb @ x) / np.linalg.norm(Y)
    Ys = Y.copy()
    sel = rows == 1
    Ys[sel] = np.roll(Y[sel], 1)
    x, *_ = np.linalg.lstsq(Wb, Ys, rcond=None)
    assert np.linalg.norm(Ys - Wb @ x) / np.linalg.norm(Ys) > 10 * r_ok


# -- the real robot ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tx40_log():
    if not TX40_DATA.is_dir():
        pytest.skip(f"the shared measured data are absent: {TX40_DATA} (expected beside the repository)")
    from tendyn.io.importer import import_logs

    return import_logs([TX40_DATA / "pos_read_data.csv", TX40_DATA / "curr_data.csv"], TX40_MAP)


def test_tx40_real_identification(tx40, tx40_log):
    assert tx40_log.n_samples == 45000 and tx40_log.meta["rate_hz"] == 5000.0
    ols = IDIM(tx40.device, method="ols").fit(tx40_log)
    wls = IDIM(tx40.device, method="wls").fit(tx40_log)
    for est in (ols, wls):
        res = est.result_
        for j in range(1, 7):
            assert est.params_[est.names_.index(f"FV{j}")] > 0, f"FV{j}"
            assert est.params_[est.names_.index(f"FS{j}")] > 0, f"FS{j}"
        assert res.residual_rel < 0.10
        assert res.crossval["residual_rel"] < 0.15          # the second half, predicted from the first
    assert ols.names_ == wls.names_
    good = ols.rel_stderr_ < 5.0
    diff = np.abs(ols.params_ - wls.params_)
    bound = 3 * np.hypot(ols.stderr_, wls.stderr_)
    assert np.all(diff[good] <= bound[good]), [n for n, g, d, b in zip(ols.names_, good, diff, bound) if g and d > b]
    d = ols.result_.to_dict()
    assert {p["name"] for p in d["params"]} >= {"ZZ1R", "FV1", "FS1"}
    assert "ZZ1" in d["params"][[p["name"] for p in d["params"]].index("ZZ1R")]["expression"]


def test_tx40_essential_and_consistent(tx40, tx40_log):
    ess = IDIM(tx40.device, essential=True).fit(tx40_log, crossval=False)
    full = IDIM(tx40.device).fit(tx40_log, crossval=False)
    assert len(ess.names_) < len(full.names_)
    assert ess.result_.residual_rel < 1.05 * full.result_.residual_rel
    pytest.importorskip("cvxpy")
    con = IDIM(tx40.device, consistent=True).fit(tx40_log, crossval=False)
    assert con.result_.residual_rel < 0.12
    for j in range(1, 7):
        assert con.params_[con.names_.index(f"FV{j}")] >= 0
    x = con.standard_params_                       # a physical mass distribution per link
    for j in range(1, 7):
        g = {p: x[f"{p}{j}"] for p in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")}
        I = np.array([[g["XX"], g["XY"], g["XZ"]], [g["XY"], g["YY"], g["YZ"]], [g["XZ"], g["YZ"], g["ZZ"]]])
        h = np.array([g["MX"], g["MY"], g["MZ"]])
        J = np.block([[0.5 * np.trace(I) * np.eye(3) - I, h[:, None]], [h[None, :], np.array([[g["M"]]])]])
        assert np.linalg.eigvalsh(J).min() > -1e-7, f"link {j}"


# -- import map ----------------------------------------------------------------------------------------

def test_import_map_errors(tmp_path):
    from tendyn.io import LogError
    from tendyn.io.importer import import_logs

    raw = tmp_path / "pos.csv"
    raw.write_text("Joint_1,Joint_2\n0.1,0.2\n0.3,0.4\n")
    mp = tmp_path / "map.toml"
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 100.0\n'
                  '[[signals]]\ncolumn = "Joint_7"\nsignal = "q_motor_1"\n')
    with pytest.raises(LogError, match=r"map.toml: signals\[1\]\.column: no column 'Joint_7' in pos.csv "
                                       r"\(columns: Joint_1, Joint_2\)"):
        import_logs([raw], mp)
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 100.0\n'
                  '[[signals]]\ncolumn = "Joint_1"\nsignal = "q_motr_1"\n')
    with pytest.raises(LogError, match=r"signals\[1\]\.signal: 'q_motr_1' is not a log column name"):
        import_logs([raw], mp)
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\n'
                  '[[signals]]\ncolumn = "Joint_1"\nsignal = "q_motor_1"\nscale = 2.0\n')
    with pytest.raises(LogError, match=r"log.rate_hz: required"):
        import_logs([raw], mp)
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 100.0\n'
                  '[[signals]]\ncolumn = "Joint_1"\nsignal = "q_motor_1"\nscale = 2.0\n')
    log = import_logs([raw], mp)
    np.testing.assert_allclose(log["q_motor_1"], [0.2, 0.6])
    np.testing.assert_allclose(log.time, [0.0, 0.01])


# -- command line --------------------------------------------------------------------------------------

def test_cli_log_import_and_identify_json(tmp_path, capsys):
    if not TX40_DATA.is_dir():
        pytest.skip(f"the shared measured data are absent: {TX40_DATA}")
    from tendyn.cli import main

    log = tmp_path / "tx40.parquet"
    assert main(["log", "import", str(TX40_DATA / "pos_read_data.csv"), str(TX40_DATA / "curr_data.csv"),
                 "--map", str(TX40_MAP), "--out", str(log)]) == 0
    capsys.readouterr()
    out = tmp_path / "params.json"
    assert main(["identify", "tx40", str(log), "--out", str(out), "--json"]) == 0   # default: consistent when not physical
    doc = json.loads(capsys.readouterr().out)
    for key in ("device", "method", "cond", "n_rows", "residual_rel", "per_joint_residual_rel", "params", "crossval"):
        assert key in doc, key
    assert doc["device"] == "tx40" and len(doc["per_joint_residual_rel"]) == 6
    # the real TX40 log's plain fit is not physical: identify reports the consistent one and says so (issue 40)
    assert doc["method"] == "ols" or (doc["method"] == "ols+consistent" and "not physical" in doc["warnings"][0])
    assert set(doc["params"][0]) == {"name", "value", "stderr", "rel_stderr_pct", "unit", "expression"}
    assert "residual_rel" in doc["crossval"]
    assert json.loads(out.read_text())["params"] == doc["params"]
    report = tmp_path / "report"
    assert main(["identify", "--plain", "tx40", str(log), "--method", "wls", "--report", str(report), "--quiet"]) == 0
    assert (report / "table.txt").read_text().startswith("tx40: base parameters (WLS)")
    assert (report / "torques.png").stat().st_size > 1000
    capsys.readouterr()
    assert main(["identify", "--plain", "tx40", str(log), "--stream", "--json"]) == 0
    streamed = json.loads(capsys.readouterr().out)
    assert streamed["method"] == "ols+stream" and len(streamed["params"]) == len(doc["params"])
    db = tmp_path / "history.sqlite"                  # --record: the base parameters and σ in the history
    assert main(["identify", "--plain", "tx40", str(log), "--out", str(out), "--record", "--db", str(db), "--quiet"]) == 0
    from tendyn.ident.history import history

    recorded = {r["name"]: (r["value"], r["sigma"]) for r in history(load_device(bundled("tx40")), db=db).rows}
    assert recorded == {p["name"]: (p["value"], p["stderr"]) for p in json.loads(out.read_text())["params"]}
    bad = tmp_path / "no_torque.csv"
    from tendyn.io import write_log

    write_log(make_log({"time": [0.0, 0.1], **{f"q_motor_{i}": [0.0, 0.0] for i in range(1, 7)}}, device="tx40",
                       rate_hz=10.0, seed=None, experiment="exciting"), bad)
    assert main(["identify", "--plain", "tx40", str(bad)]) == 2
    assert "no_torque.csv: column torque_motor_: identification needs the motor torques" in capsys.readouterr().err
    assert main(["identify", "--plain", "tx40", str(log), "--cutoff-hz", "3000"]) == 2
    assert "--cutoff-hz: must be below half the log rate" in capsys.readouterr().err


# -- scale: chunked normal equations, Dask campaign -------------------------------------------------------

def test_streaming_equals_in_memory(tx40):
    from tendyn.ident.stream import accumulate, solve_normal

    log = _synthetic_tx40(tx40, noise=0.01)
    tr = Treatment(20.0, 4, 10, 0.0, 1000.0, 10.0)
    est = IDIM(tx40.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(log, crossval=False)
    time, q, tau = tx40.joint_signals(log)
    chunks = ((time[i:i + 997], q[i:i + 997], tau[i:i + 997]) for i in range(0, time.size, 997))
    ne, _ = accumulate(tx40, chunks, 1000.0, tr)
    assert int(ne.r.sum()) == est.result_.n_rows
    x, se, cond, resid, per = solve_normal(ne)
    np.testing.assert_allclose(x, est.params_, rtol=1e-7, atol=1e-9 * np.max(np.abs(est.params_)))
    np.testing.assert_allclose(se, est.stderr_, rtol=1e-5)
    assert resid == pytest.approx(est.result_.residual_rel, rel=1e-6)
    np.testing.assert_allclose(per, est.result_.per_joint_residual_rel, rtol=1e-6)


def test_campaign_on_a_dask_scheduler(tx40):
    distributed = pytest.importorskip("dask.distributed")
    logs = [_synthetic_tx40(tx40, noise=0.01, seed=s) for s in (1, 2)]
    here = IDIM(tx40.device, cutoff_hz=20.0, decimate=10).fit(logs, crossval=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        there = IDIM(tx40.device, cutoff_hz=20.0, decimate=10, scheduler=cluster.scheduler_address).fit(
            logs, crossval=False)
    # the same per-log reduction (compact factors) on the worker as here, the same combination: the same bits
    np.testing.assert_array_equal(there.params_, here.params_)
    np.testing.assert_array_equal(there.stderr_, here.stderr_)
    np.testing.assert_array_equal(there.result_.y_hat, here.result_.y_hat)
    assert there.cond_ == here.cond_ and there.result_.n_rows == here.result_.n_rows


@pytest.fixture(scope="module")
def two_short_logs(tx40):
    return [_synthetic_tx40(tx40, noise=0.01, seed=s, duration=3.0) for s in (5, 6)]


@pytest.mark.parametrize("plant", [None, "a log's y column dropped"])
@pytest.mark.parametrize("method", ["ols", "wls"])
def test_compact_factors_equal_the_stacked_rows(tx40, two_short_logs, monkeypatch, plant, method):
    """IDIM reduces each log to per-joint R factors of [W_base | y] (lsq.row_factor) and solves on their stack:
    x, σ, the per-joint residuals (WLS weights) and cond equal those of lstsq on the stacked rows to 1e-10.
    The plant drops the second log's y column from its factors (as if that log had y = 0): seen."""
    import tendyn.ident.estimate as estimate
    from tendyn.ident.lsq import least_squares

    logs = two_short_logs
    if plant:
        calls = []

        def dropped(W, y):
            calls.append(1)
            R = np.linalg.qr(np.column_stack([W, y]), mode="r")
            if len(calls) > tx40.n_active:          # the second log's joints
                R[:, -1] = 0.0
            return R
        monkeypatch.setattr(estimate, "row_factor", dropped)
    est = IDIM(tx40.device, cutoff_hz=20.0, decimate=10, method=method)
    C, S = est._system(logs, compact=True), est._system(logs, compact=False)
    C.close()
    S.close()
    assert S.stats is None and C.stats[2] == S.Y.size and C.Y.size <= 2 * tx40.n_active * (C.Wb.shape[1] + 1)
    na = tx40.n_active
    xc, sec, wc = est._solve(C.Wb, C.Y, C.rows, na, stats=C.stats)
    xs, ses, ws = est._solve(S.Wb, S.Y, S.rows, na)
    ref = np.max(np.abs(xs))
    per_c = [np.linalg.norm((C.Y - C.Wb @ xs)[C.rows == j]) for j in range(na)]
    per_s = [np.linalg.norm((S.Y - S.Wb @ xs)[S.rows == j]) for j in range(na)]
    sv_c = np.linalg.svd(C.Wb * wc[:, None], compute_uv=False)
    sv_s = np.linalg.svd(S.Wb * ws[:, None], compute_uv=False)
    errors = [np.max(np.abs(xc - xs)) / ref, np.max(np.abs(sec / ses - 1)), np.max(np.abs(np.divide(per_c, per_s) - 1)),
              abs(sv_c[0] / sv_c[-1] / (sv_s[0] / sv_s[-1]) - 1)]
    if plant:
        assert max(errors) > 1e-3, errors
    else:
        assert max(errors) < 1e-10, errors
        x_rows = least_squares(S.Wb, S.Y)[0]             # the one lstsq on the rows
        np.testing.assert_allclose(least_squares(C.Wb, C.Y, n_obs=C.stats[2])[0], x_rows, rtol=0, atol=1e-10 * ref)


def test_streaming_estimator_on_a_parquet_log(tx40, tmp_path):
    from tendyn.ident.stream import StreamingIDIM
    from tendyn.io import write_log

    log = _synthetic_tx40(tx40, noise=0.01, seed=4)
    path = write_log(log, tmp_path / "big.parquet")
    est = IDIM(tx40.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(log, crossval=False)
    st = StreamingIDIM(tx40.device, cutoff_hz=20.0, decimate=10, chunk_rows=1234, velocity_threshold=0.0).fit(path)
    np.testing.assert_allclose(st.params_, est.params_, rtol=1e-7, atol=1e-9 * np.max(np.abs(est.params_)))
    assert st.result_.n_rows == est.result_.n_rows
    assert st.result_.crossval["residual_rel"] < 0.05
    assert type(st.result_.plot()).__name__ == "Figure"


def test_prefetch_keeps_order_raises_where_the_reader_failed_and_stops_early():
    """The background reader of the streaming fit: same items in the same order; a reader error reaches the
    caller after the items before it; a consumer that stops early does not leave the reader hanging."""
    import itertools
    import threading

    from tendyn.ident.stream import prefetch

    assert list(prefetch(iter(range(50)))) == list(range(50))

    def failing():
        yield 1
        yield 2
        raise OSError("disk gone")

    got = []
    with pytest.raises(OSError, match="disk gone"):
        for x in prefetch(failing()):
            got.append(x)
    assert got == [1, 2]
    before = threading.active_count()
    g = prefetch(itertools.count())
    assert [next(g) for _ in range(3)] == [0, 1, 2]
    g.close()
    assert threading.active_count() == before
