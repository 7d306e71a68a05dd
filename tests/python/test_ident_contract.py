"""One estimator contract (issue 18 item 1): IDIM, StreamingIDIM, the S0 transmission friction and the capstan
stiffness share one least squares and one %σ (tendyn.ident.lsq); --stream honours every treatment option (stale
rows, re-timing, logged velocities, the velocity threshold) and agrees with the in-memory fit; a pseudo-inertia
that is not positive definite is flagged (item 5).

Logs are generated here from a generated 2-joint cable arm (RNEA + friction chosen by the test, as in
test_ident_real_logs); the estimators read only the logs.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.ident import IDIM
from tendyn.ident.lsq import IdentificationError, least_squares, rel_stderr_pct

from test_ident_real_logs import arm, synthetic_log, with_stale_rows  # noqa: F401 (fixture)


def test_one_least_squares_on_rows_and_on_normal_equations():
    """The W route and the normal-equation route of the one routine give the same x, σ (S2 eqs. 4–6: σ̂² with the
    squared norm over r − b); weights scale rows by √w; %σ = 100 σ/|x|, infinite at 0."""
    rng = np.random.default_rng(0)
    W = rng.normal(size=(200, 4))
    y = W @ np.array([1.0, -2.0, 0.5, 3.0]) + 0.1 * rng.normal(size=200)
    x, se, s2, cov = least_squares(W, y)
    res = y - W @ x
    assert s2 == pytest.approx(res @ res / 196)                      # the square, r − b
    xn, sen, s2n, _ = least_squares(normal=(W.T @ W, W.T @ y, float(y @ y), 200))
    np.testing.assert_allclose(xn, x, rtol=1e-10)
    np.testing.assert_allclose(sen, se, rtol=1e-6)
    w = rng.uniform(0.5, 2.0, 200)
    xw, *_ = least_squares(W, y, weights=w)
    xs, *_ = least_squares(W * np.sqrt(w)[:, None], y * np.sqrt(w))
    np.testing.assert_allclose(xw, xs, rtol=1e-12)
    np.testing.assert_allclose(rel_stderr_pct([0.1, 0.2], [-2.0, 0.0]), [5.0, np.inf])
    with pytest.raises(IdentificationError, match="4 rows for 4 parameters"):
        least_squares(W[:4], y[:4])


def test_every_estimator_follows_the_contract(tmp_path):
    """CapstanStiffness and TransmissionFriction: fit returns self, learned values end in _, predict, score,
    get_params; the capstan's numbers are those of fit_capstan_stiffness (the pipeline's function)."""
    from tendyn.io import make_log
    from tendyn.ident.friction import TransmissionFriction
    from tendyn.pipelines.s2_stiffness import CapstanStiffness, fit_capstan_stiffness

    rate = 1000.0
    t = np.arange(4000) / rate
    dq = 0.01 * (2 * np.abs(((t * 0.5) % 1.0) - 0.5) - 0.5)
    torque = 300.0 * dq + 0.4 * np.gradient(dq, 1 / rate) + 0.05
    torque += 0.001 * np.random.default_rng(1).normal(size=t.size)
    log = make_log({"time": t, "q_motor_1": dq, "torque_motor_1": torque}, device="x", rate_hz=rate, seed=0,
                   experiment="blocked-link")
    est = CapstanStiffness(1, cutoff_hz=50.0)
    assert est.fit(log) is est
    assert est.params_[0] == pytest.approx(300.0, rel=1e-2)
    fit = fit_capstan_stiffness(log, 1)
    assert fit.K == est.params_[0] and np.array_equal(fit.stderr, est.stderr_)
    assert est.predict(log).shape == t.shape and est.score(log) < 0.05
    assert CapstanStiffness(**est.get_params()).fit(log).params_[0] == est.params_[0]
    assert est.treatment_.cutoff_hz == 50.0
    fr = TransmissionFriction(1)
    for name in ("fit", "predict", "score", "get_params"):
        assert callable(getattr(fr, name))


def test_stream_and_in_memory_agree_with_stale_rows_and_logged_velocities(arm, tmp_path):  # noqa: F811
    """A log with 15 % stale rows, time stamps off the grid and logged velocities: --stream drops and re-times
    the same rows (counted in its treatment), uses the logged velocities, and finds the in-memory parameters."""
    from tendyn.ident.stream import StreamingIDIM
    from tendyn.io import write_log

    log = synthetic_log(arm, rate_hz=1000.0, duration=10.0, seed=12, noise=0.01, velocities=True)
    log, n_stale = with_stale_rows(log, 0.15, seed=3)
    path = write_log(log, tmp_path / "log.parquet")
    for vel in ("auto", "differentiate"):
        kw = dict(cutoff_hz=20.0, decimate=10, velocities=vel)
        mem = IDIM(arm.device, **kw).fit(log, crossval=False)
        st = StreamingIDIM(arm.device, chunk_rows=777, **kw).fit(path)
        assert st.treatment_.stale_dropped == mem.treatment_.stale_dropped == n_stale
        assert st.treatment_.retimed and mem.treatment_.retimed
        assert st.treatment_.velocities == mem.treatment_.velocities == ("logged" if vel == "auto" else
                                                                         "differentiate")
        assert st.result_.n_rows == mem.result_.n_rows
        np.testing.assert_allclose(st.params_, mem.params_, rtol=1e-6, atol=1e-8 * np.max(np.abs(mem.params_)))
        np.testing.assert_allclose(st.stderr_, mem.stderr_, rtol=1e-5)


def test_stream_reads_a_clean_log_twice_and_a_stale_one_three_times(arm, tmp_path, monkeypatch):  # noqa: F811
    """The stale-row scan rides on the speed pass: a clean log is read twice (speeds + scan, then the sums), a log
    with stale rows three times (the speed pass again on the re-timed batches). Counted by wrapping the Parquet
    reader; the parameters still equal the in-memory ones."""
    import tendyn.ident.stream as stream
    from tendyn.io import write_log

    reads = []
    reader = stream.iter_parquet_chunks

    def counting(*a, **k):
        reads.append(k.get("torques", True))
        return reader(*a, **k)

    monkeypatch.setattr(stream, "iter_parquet_chunks", counting)
    log = synthetic_log(arm, rate_hz=1000.0, duration=6.0, seed=5, noise=0.01)
    for name, lg, passes in (("clean", log, 2), ("stale", with_stale_rows(log, 0.1, seed=2)[0], 3)):
        reads.clear()
        path = write_log(lg, tmp_path / f"{name}.parquet")
        st = stream.StreamingIDIM(arm.device, chunk_rows=999, cutoff_hz=20.0, decimate=10).fit(path)
        assert len(reads) == passes, (name, reads)
        assert st.treatment_.retimed == (name == "stale")
        mem = IDIM(arm.device, cutoff_hz=20.0, decimate=10).fit(lg, crossval=False)
        np.testing.assert_allclose(st.params_, mem.params_, rtol=1e-6, atol=1e-8 * np.max(np.abs(mem.params_)))


def test_cli_stream_takes_the_velocities_option_and_prints_the_treatment(arm, tmp_path, capsys):  # noqa: F811
    from tendyn.cli import main
    from tendyn.io import write_log

    path = write_log(synthetic_log(arm, duration=6.0, seed=7, noise=0.01, velocities=True), tmp_path / "l.parquet")
    for opt, said in ((["--velocities", "differentiate"], "differentiate"), ([], "logged")):
        assert main(["identify", str(arm.file), str(path), "--stream", "--json", *opt]) == 0
        out = capsys.readouterr()
        assert json.loads(out.out)["treatment"]["velocities"] == said
        assert "treatment:" in out.err


def test_pseudo_inertia_not_positive_definite_is_flagged(arm, tmp_path, capsys):  # noqa: F811
    """A correct fit passes the pseudo-inertia check (its link 1, a near-singular rod in the file, fails the quick
    check with the file's inseparable values and is cleared by the SDP over every completion); a fit whose ZZ2 is
    negative (no completion can make link 2's J positive: S_xx + S_yy = ZZ2) is flagged in the table, the
    warnings and the JSON, with --consistent named; the consistent estimate is not flagged."""
    log = synthetic_log(arm, duration=8.0, seed=9, noise=0.01)
    est = IDIM(arm.device, cutoff_hz=20.0, decimate=10).fit(log, crossval=False)
    assert [p["link"] for p in est.result_.pseudo_inertia] == [1, 2]
    assert all(p["ok"] for p in est.result_.pseudo_inertia)
    res = est.result_
    res.values = res.values.copy()
    res.values[res.names.index("ZZ2")] = -0.01
    res.warnings = []
    res.flag_pseudo_inertia(arm)
    bad = [p for p in res.pseudo_inertia if not p["ok"]]
    assert [p["link"] for p in bad] == [2] and bad[0]["min_eigenvalue"] < -1e-4
    assert any(w.startswith("link 2: pseudo-inertia not positive definite") and "--consistent" in w
               for w in res.warnings)
    assert "warning: link 2: pseudo-inertia" in res.table()
    d = res.to_dict()
    assert [p["link"] for p in d["pseudo_inertia"] if not p["ok"]] == [2]
    json.dumps(d)
    cons = IDIM(arm.device, cutoff_hz=20.0, decimate=10, consistent=True).fit(log, crossval=False)
    assert all(p["ok"] for p in cons.result_.pseudo_inertia)


def test_logged_joint_velocities_read_like_motor_velocities(arm):  # noqa: F811
    """One rule for logged velocities (IdentModel.velocity_columns, in memory and streamed): ``qd_joint_<j>`` of
    every active joint, when the motors' are absent, give the same joint velocities as ``qd_motor_<i>`` through
    G⁻¹; an incomplete set of either is no logged velocity."""
    from tendyn.io.logs import make_log

    log = synthetic_log(arm, rate_hz=1000.0, duration=2.0, seed=5, velocities=True)
    qd = arm.joint_velocities(log)
    cols = {k: np.asarray(log[k]) for k in log.columns if not k.startswith("qd_motor_")}
    cols.update({f"qd_joint_{n}": qd[:, k] for k, n in enumerate(arm.active_numbers)})
    joint_log = make_log(cols, device=arm.device.name, rate_hz=1000.0, seed=5, experiment="exciting")
    np.testing.assert_allclose(arm.joint_velocities(joint_log), qd, rtol=1e-12, atol=1e-12)
    motors = [f"qd_motor_{i + 1}" for i in range(arm.n_motors)]
    assert arm.velocity_columns(["time", *motors]) == motors
    assert arm.velocity_columns(["time", *motors[1:]]) is None


def test_bounds_constrain_the_consistent_fit(arm):  # noqa: F811
    """``IDIM(bounds=...)`` (a peer's boxes, WPI's dVRK SDP): a box on a standard parameter and on a centre of
    mass (CX2 = MX2 / M2 [m], linear as lo·M ≤ MX ≤ hi·M) is met by the consistent estimate and moves it; unknown
    names, lower > upper and bounds without consistent=True are refused. Plant seen failing: the centre-of-mass
    box written on MX2 itself (not times M2)."""
    log = synthetic_log(arm, duration=6.0, seed=4, noise=0.01)
    free = IDIM(arm.device, cutoff_hz=20.0, decimate=10, consistent=True).fit(log, crossval=False)
    s0 = free.standard_params_
    fv_hi = 0.5 * s0["FV1"]
    cx = s0["MX2"] / s0["M2"]
    box = (cx + 0.05, cx + 0.1) if cx < 0 else (cx - 0.1, cx - 0.05)     # a box that excludes the free value
    est = IDIM(arm.device, cutoff_hz=20.0, decimate=10, consistent=True,
               bounds={"FV1": (None, fv_hi), "CX2": box, "M2": (0.5 * s0["M2"], 2.0 * s0["M2"])}).fit(
        log, crossval=False)
    s = est.standard_params_
    tol = 1e-6 * max(1.0, abs(fv_hi))
    assert s["FV1"] <= fv_hi + tol and abs(s["FV1"] - fv_hi) < 1e-3 * abs(fv_hi) + tol    # active
    assert box[0] - 1e-5 <= s["MX2"] / s["M2"] <= box[1] + 1e-5
    assert est.result_.residual_rel > free.result_.residual_rel
    for bad, match in (({"FOO": (0, 1)}, "not a standard parameter"), ({"M2": (2.0, 1.0)}, "lower"),
                       ({"CX9": (0, 1)}, "not a standard parameter")):
        with pytest.raises(ValueError, match=match):
            IDIM(arm.device, cutoff_hz=20.0, decimate=10, consistent=True, bounds=bad).fit(log, crossval=False)
    with pytest.raises(ValueError, match="consistent=True"):
        IDIM(arm.device, cutoff_hz=20.0, decimate=10, bounds={"M2": (0, 1)}).fit(log, crossval=False)
