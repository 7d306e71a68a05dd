"""S0 friction identification (issue 8, items 1–4): plateaus from a quantised encoder, the constant-velocity
estimator (C7), S1 vs S2 on the L-EXOS twin (C8), the loss decomposition (C9), FRICTION.json and the
commands ``plan``, ``identify-friction``, ``decompose``.

The twin runs are short (8 rad of motor travel, five speeds 4…12 rad/s, ~15 s of wall time for all eight);
the pipeline's full runs use longer strokes (``tendyn.pipelines.s0_friction``)."""

import argparse
import json
import math

import matplotlib
import numpy as np
import pytest

from tendyn.claims import assert_claim, twins
from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.errors import UsageError
from tendyn.ident import (FrictionFileError, IdentificationError, TransmissionFriction, decompose,
                          default_shares, find_plateaus, kinematic_coefficients, read_friction,
                          residual_error_bound, write_friction)
from tendyn.ident.decomposition import read_shares, true_shares
from tendyn.ident.friction import least_squares
from tendyn.ident.friction_file import friction_document
from tendyn.io import make_log, read_log, truth_path, write_log
from tendyn.pipelines import s0_friction as sf
from tendyn.sim.experiments import constant_velocity_profile

SPEEDS = twins.FRICTION_SPEEDS
TRAVEL_MOTOR = twins.FRICTION_TRAVEL
STEP = 2 * np.pi / 16384          # L-EXOS encoder: 4096 counts × 4


@pytest.fixture(scope="module")
def lexos():
    return load_device(bundled("lexos"))


@pytest.fixture(scope="module")
def comparison(claims_ctx):
    """S1 and S2 on every transmission of the twin (short strokes), fitted from the logs alone."""
    return twins.friction_comparison(claims_ctx)


def synthetic_log(c0=0.025, nu=0.002, noise=0.007, seed=0, speeds=(2, 4, 6, 8, 10), travel=6.0,
                  gravity_amp=0.05, experiment="constant_velocity_S2"):
    """A constant-velocity log with an analytic oracle: C = g(q) + C0 sgn(v) + ν v + white noise, where
    g depends on the position only (as gravity does), quantised encoder, exact trapezoidal speeds."""
    rng = np.random.default_rng(seed)
    dt = 1e-3
    pos, vel = constant_velocity_profile(speeds, travel, 200.0, dt)
    q = np.round((pos + 1.0) / STEP) * STEP
    g = 0.05 + gravity_amp * np.sin(1.3 * pos)
    c = g + c0 * np.sign(vel) + nu * vel + rng.normal(0.0, noise, pos.size)
    return make_log({"time": np.arange(pos.size) * dt, "q_motor_1": q, "torque_motor_1": c},
                    device="synthetic", rate_hz=1000.0, seed=seed, experiment=experiment,
                    options={"transmission": 1})


# ---- plateaus -----------------------------------------------------------------------------------------

def test_plateaus_found_from_quantised_encoder_only():
    log = synthetic_log(noise=0.0)
    ps = find_plateaus(log.time, log["q_motor_1"])
    speeds = sorted(p.speed for p in ps)
    expected = sorted([v for v in (2, 4, 6, 8, 10)] + [-v for v in (2, 4, 6, 8, 10)])
    assert len(ps) == 10
    np.testing.assert_allclose(speeds, expected, rtol=2e-3)
    # no plateau reaches into a ramp: the true speed is constant over every plateau
    _, vel = constant_velocity_profile((2, 4, 6, 8, 10), 6.0, 200.0, 1e-3)
    for p in ps:
        assert np.ptp(vel[p.slice]) == 0.0


# ---- C7: the estimator ---------------------------------------------------------------------------------

def test_C7_synthetic_log_analytic_oracle():
    """C7 on a log with known C_m0, ν and a position-dependent 'gravity' of twice their size: the S0
    forward/backward half-differences remove it; the fit lands within 3σ of the oracle."""
    est = TransmissionFriction(1).fit(synthetic_log(gravity_amp=0.1))
    assert est.fit(synthetic_log(gravity_amp=0.1)) is est                  # fit returns self
    assert abs(est.coulomb_motor_ - 0.025) < 3 * est.stderr_[0]
    assert abs(est.viscous_motor_ - 0.002) < 3 * est.stderr_[1]
    assert est.rel_stderr_[0] < 2.0 and est.rel_stderr_[1] < 3.0         # %σ, S2 eq. 7
    assert est.strategy_ == "S2" and len(est.speeds_) == 5 and est.cond_ > 1


def test_C7_standard_deviations_match_the_scatter():
    """σ̂² = ‖r‖²/(N − p) with the square (ERRATA S2 eq. 5): over seeds, (x̂ − x)/σ has unit spread."""
    z = []
    for seed in range(24):
        est = TransmissionFriction(1).fit(synthetic_log(seed=seed, noise=0.01))
        z.append([(est.coulomb_motor_ - 0.025) / est.stderr_[0], (est.viscous_motor_ - 0.002) / est.stderr_[1]])
    spread = np.std(np.array(z), axis=0)
    assert np.all(spread > 0.6) and np.all(spread < 1.6), spread


def test_least_squares_statistics_by_hand():
    W = np.column_stack([np.ones(4), [1.0, 2.0, 3.0, 4.0]])
    y = np.array([1.0, 2.1, 2.9, 4.2])
    x, cov, s, cond = least_squares(W, y)
    r = y - W @ x
    assert s == pytest.approx(math.sqrt(r @ r / 2))
    np.testing.assert_allclose(cov, (r @ r / 2) * np.linalg.inv(W.T @ W))


def test_C7_needs_five_speeds_per_direction():
    with pytest.raises(IdentificationError, match="4 speeds, need at least 5"):
        TransmissionFriction(1).fit(synthetic_log(speeds=(2, 4, 6, 8)))
    with pytest.raises(IdentificationError, match="no column q_motor_2"):
        TransmissionFriction(2).fit(synthetic_log())
    with pytest.raises(ValueError, match="needs the device"):
        TransmissionFriction(1, gravity="model").fit(synthetic_log())


def test_C7_twin_logs_recover_the_truth(comparison, tmp_path, claims_ctx):
    """C7 on the twin: S2 fits of C_m0 and ν per transmission from encoders and motor torques only.
    Transmissions 2 and 4 (no distal residual that biases S2 beyond noise on these short runs) within 5 %
    (C_m0) and 10 % (ν) of the twin's true values at the test's load."""
    assert_claim("C7", claims_ctx)
    cmp, runs = comparison
    # the estimator sees only the log: written to disk without its truth sidecar it gives the same fit
    run = runs[(4, "S2")]
    path = write_log(run.log, tmp_path / "t4.parquet")
    assert not truth_path(path).exists()
    fit = TransmissionFriction(4).fit(read_log(path)).result_
    assert fit.coulomb_motor == pytest.approx(cmp.fits[(4, "S2")].coulomb_motor)
    assert "routing" not in json.dumps(read_log(path).meta)


def test_C7_gravity_model_removes_gravity_too(comparison, lexos):
    """The device's gravity model (rigid body + lossless statics) instead of the pairs: same values
    within the pair fit's noise on the twin (gravity ≈ 0.16 N·m at motor 2, C_m0 ≈ 0.04 N·m)."""
    cmp, runs = comparison
    log = runs[(2, "S2")].log
    pairs = cmp.fits[(2, "S2")]
    for mode in ("model", "both"):
        fit = TransmissionFriction(2, gravity=mode, device=lexos).fit(log).result_
        at_load = pairs.coulomb_at_load()   # the load term, when one fit keeps it, is compared at the test's load
        assert abs(fit.coulomb_at_load(pairs.mean_load_motor) - at_load) < 0.1 * at_load, mode
        assert abs(fit.viscous_motor - pairs.viscous_motor) < 0.15 * pairs.viscous_motor, mode


# ---- C8: S1 vs S2 ---------------------------------------------------------------------------------

def test_C8_S2_smaller_error_than_S1(comparison, claims_ctx):
    """C8: on every transmission that has distal joints, S2's friction error (rms over the test speeds,
    against the twin's truth) is smaller than S1's. Transmission 4 drives the last joint: with the other
    motors held the other joints are held too, so S1 and S2 are the same experiment (ERRATA eq. 14) and
    their errors agree within the noise of one run."""
    assert_claim("C8", claims_ctx)
    cmp, _ = comparison
    # S1's error is the distal sliding friction: C_m0 biased upward by about the S1 bound
    for t in (1, 3):
        f, (c0, _) = cmp.fits[(t, "S1")], cmp.truth[t]
        assert 0.5 * cmp.bounds_truth[(t, "S1")] < f.coulomb_at_load() - c0 < 2.0 * cmp.bounds_truth[(t, "S1")]


def test_C8_table_figure_and_dict(comparison):
    cmp, _ = comparison
    text = cmp.table()
    assert "S2 smaller error" in text and text.count("\n") >= 9
    doc = json.loads(json.dumps(cmp.to_dict(), allow_nan=False))
    assert [r["transmission"] for r in doc["transmissions"]] == [1, 2, 3, 4]
    backend = matplotlib.get_backend()
    fig = cmp.plot()
    assert type(fig).__name__ == "Figure" and len(fig.axes[0].patches) == 8
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    assert cmp.plot(ax) is ax.figure
    assert cmp.fits[(2, "S2")].plot() is not None
    assert matplotlib.get_backend() == backend


def test_true_global_values_two_routes(lexos):
    """The pipeline's truth: eqs. 18–19 with β, bearings and reducers in Python agree with the core's
    statics with losses (Transmission.feedforward), at zero load and under the test's gravity load;
    with β = 0 the zero-load values are exactly C_m0 = Σ τ_0 |k'| and ν = Σ ν k'² (k' = r_m)."""
    arr = lexos.routing_arrays()
    for j in range(4):
        np.testing.assert_allclose(sf.true_global_friction(arr, j), sf.true_global_feedforward(arr, j), rtol=1e-12)
        q0, travel, _ = sf.stroke_plan(lexos, j + 1, TRAVEL_MOTOR, SPEEDS)
        np.testing.assert_allclose(sf.true_global_at_load(arr, lexos, j + 1, q0, travel, SPEEDS, route="python"),
                                   sf.true_global_at_load(arr, lexos, j + 1, q0, travel, SPEEDS, route="core"),
                                   rtol=1e-10)
    a0 = dict(arr, beta=np.zeros_like(arr["beta"]))
    kp = kinematic_coefficients(arr["K"], arr["motor_radius"])
    for j in range(4):
        c0, nu = sf.true_global_friction(a0, j)
        assert c0 == pytest.approx(np.sum(arr["tau0"][j] * np.abs(kp[j])))
        assert nu == pytest.approx(np.sum(arr["nu"][j] * kp[j] ** 2))


def test_statics_treats_branches_beyond_the_moving_joint_as_still(lexos):
    """Only joint 1 moves: every branch beyond it is exactly still (Ṡ = 0, stuck), so motor 1 pays only
    its own cable's friction — the core once summed Ṡ by differences and left 4e-19 (a random sign)."""
    from tendyn.transmission import Transmission

    tr = Transmission.from_device(lexos)
    arr = lexos.routing_arrays()
    for v in (2.0, 6.0, 10.0):
        qd = np.array([v * 0.008 / 0.32, 0, 0, 0])
        S = tr.branch_velocities(qd)
        assert np.all(S[1:, 1:] == 0.0)
        res = tr.feedforward(np.zeros(4), qd)
        assert res.torque_motor[0] == pytest.approx(sf.true_motor_friction(arr, 0, v), rel=1e-12)


def test_residual_bound_eq15_by_hand(lexos):
    arr = lexos.routing_arrays()
    # S2, transmission 1: (r_m / r_1^1) Σ_{k>1} |r_1^k| Σ_{branches beyond joint 1} τ_0 = 0.025 · 0.015 · (1+2+3)
    assert residual_error_bound(arr["K"], arr["motor_radius"], 0, "S2", arr["tau0"]) == pytest.approx(2.25e-3)
    assert residual_error_bound(arr["K"], arr["motor_radius"], 3, "S2", arr["tau0"]) == 0.0
    # S1, transmission 3: branch 3 of transmission 4 slides at k' = -r_3^4 r_m / r_3^3
    b = residual_error_bound(arr["K"], arr["motor_radius"], 2, "S1", arr["tau0"], arr["nu"], 10.0)
    kp = 0.015 * 0.008 / 0.09
    assert b == pytest.approx(1.0 * kp + 10.0 * kp ** 2 * 10.0)


def test_estimator_reports_the_bound_of_its_strategy(lexos):
    arr = lexos.routing_arrays()
    log = synthetic_log(experiment="constant_velocity_S2")
    est = TransmissionFriction(1, device=lexos, bound_tau0=arr["tau0"], bound_nu=arr["nu"]).fit(log)
    assert est.residual_bound_ == pytest.approx(2.25e-3) and est.result_.to_dict()["residual_bound"] == est.residual_bound_
    assert TransmissionFriction(1).fit(log).residual_bound_ is None
    assert "ERRATA eq. 15) 0.00225 N·m" in str(est.result_)


# ---- C9: decomposition --------------------------------------------------------------------------------

def test_C9_decomposition_reproduces_the_global_values_exactly(comparison, lexos, claims_ctx):
    """C9: ν̂_j = γ_j ν, τ̂_0,j = α_j C_m0 with γ = p/k'², α = p'/|k'| (ERRATA eqs. 20–21) give back ν and
    C_m0 through eqs. 18–19 to rounding, for any shares that sum to 1."""
    assert_claim("C9", claims_ctx)
    cmp, _ = comparison
    c0 = [cmp.fits[(t, "S2")].coulomb_motor for t in range(1, 5)]
    nu = [cmp.fits[(t, "S2")].viscous_motor for t in range(1, 5)]
    dec = decompose(lexos, c0, nu)
    np.testing.assert_allclose(dec.kprime[np.tril_indices(4)], 0.008)         # k' = r_m (ERRATA eq. 16)
    np.testing.assert_allclose(default_shares(lexos)[0].sum(axis=1), 1.0)


def test_C9_true_shares_recover_the_twin_branches(comparison, lexos):
    """With the twin's true shares, the decomposition of the twin's global values (eqs. 18–19) returns the
    twin's per-branch τ_0 and ν exactly; from the identified S2 values it returns them within the
    identification error (default shares are the true ones on L-EXOS: one pulley per branch, equal losses)."""
    arr = lexos.routing_arrays()
    kp = kinematic_coefficients(arr["K"], arr["motor_radius"])
    c0 = (arr["tau0"] * np.abs(kp)).sum(axis=1)
    nu = (arr["nu"] * kp ** 2).sum(axis=1)
    p, pp = true_shares(arr["nu"], arr["tau0"], kp)
    dec = decompose(lexos, c0, nu, p, pp)
    np.testing.assert_allclose(dec.tau0_branch, arr["tau0"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(dec.nu_branch, arr["nu"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(default_shares(lexos)[1], pp)
    cmp, _ = comparison
    c0_hat = [cmp.fits[(t, "S2")].coulomb_motor for t in range(1, 5)]
    nu_hat = [cmp.fits[(t, "S2")].viscous_motor for t in range(1, 5)]
    est = decompose(lexos, c0_hat, nu_hat)
    true = decompose(lexos, [cmp.truth[t][0] for t in range(1, 5)], [cmp.truth[t][1] for t in range(1, 5)])
    np.testing.assert_allclose(est.tau0_branch[3], true.tau0_branch[3], rtol=0.05)   # transmission 4
    np.testing.assert_allclose(est.nu_branch[3], true.nu_branch[3], rtol=0.10)


def test_shares_file(lexos, tmp_path):
    rows = [{"transmission": i, "p": [1.0 / i] * i, "p_prime": [1.0 / i] * i} for i in range(1, 5)]
    path = tmp_path / "shares.json"
    path.write_text(json.dumps({"format": "tendyn.shares/1", "transmissions": rows}))
    p, pp = read_shares(path, lexos)
    np.testing.assert_allclose(p, default_shares(lexos)[0])
    rows[2]["p"] = [0.5, 0.5, 0.5]
    path.write_text(json.dumps({"format": "tendyn.shares/1", "transmissions": rows}))
    with pytest.raises(ValueError, match=r"transmissions\[3\]\.p: must sum to 1"):
        read_shares(path, lexos)


# ---- FRICTION.json --------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def friction_doc(comparison, lexos):
    cmp, _ = comparison
    return friction_document(lexos.name, [cmp.fits[(t, "S2")] for t in range(1, 5)])


def test_friction_file_round_trip(friction_doc, lexos, tmp_path):
    path = write_friction(friction_doc, tmp_path / "friction.json")
    doc = read_friction(path, device=lexos)
    assert doc["format"] == "tendyn.friction/1" and len(doc["coulomb_motor"]) == 4
    assert doc["fits"][1]["speeds_motor"] == pytest.approx(list(SPEEDS), rel=0.02)


@pytest.mark.parametrize("damage, field", [
    (lambda d: d["fits"].pop(2), "fits: transmission 3 missing"),
    (lambda d: d["coulomb_motor"].pop(), "coulomb_motor: 3 values for 4 transmissions (transmission 4 missing)"),
    (lambda d: d["viscous_motor"].__setitem__(1, float("nan")), "viscous_motor[2]: must be a finite number"),
    (lambda d: d["fits"][0].__setitem__("coulomb_motor_std", float("nan")),
     "fits[1].coulomb_motor_std: must be a finite number"),
    (lambda d: d.__setitem__("device", "CEA branch"), "device: the file is about 'CEA branch', not 'L-EXOS'"),
    (lambda d: d.__setitem__("format", "tendyn.friction/9"), "format: must be 'tendyn.friction/1'"),
])
def test_bad_friction_file_refused_naming_the_field(friction_doc, lexos, tmp_path, damage, field):
    doc = json.loads(json.dumps(friction_doc))
    damage(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))                  # json writes NaN as the bare token NaN
    with pytest.raises(FrictionFileError) as err:
        read_friction(path, device=lexos)
    assert field in str(err.value) and str(path) in str(err.value)
    assert "\n" not in str(err.value)
    # the decompose command refuses it the same way, as a usage error (exit 2)
    from tendyn.commands import s0

    args = argparse.Namespace(device="lexos", friction=path, shares=None, json=True)
    with pytest.raises(UsageError, match=field.split(":")[0].replace("[", r"\[").replace("]", r"\]")):
        s0.run_decompose(args)


# ---- commands ---------------------------------------------------------------------------------------------

def _parse(argv):
    from tendyn.commands import s0

    p = argparse.ArgumentParser(prog="tendyn")
    s0.register(p.add_subparsers(dest="command", required=True))
    return p.parse_args(argv)


def test_plan_writes_the_twins_references(lexos, tmp_path):
    """``tendyn plan`` writes exactly the references the twin's experiment runs (same function, same grid).
    At 2 kHz (the grid is the option's: 10 kHz wrote 91 MB of CSV per strategy, 5 × the time, same code)."""
    from tendyn.commands import s0
    from tendyn.protocols import references as cv_references
    from tendyn.sim.model import sim_model

    out = tmp_path / "ref.csv"
    for strategy, prefix in (("S1", "q_motor_ref_"), ("S2", "q_ref_")):
        args = _parse(["plan", "constant-velocity", "lexos", "--transmission", "2", "--strategy", strategy,
                       "--rate", "2000", "--out", str(out), "--json"])
        assert s0.run_plan(args) == 0
        ref = read_log(out)
        m = sim_model(lexos, rate_hz=2_000.0)
        Gm = np.array(m.tendon.motor_from_joint_position)
        # the twin's run with the same options (tendyn simulate's catalogue) plans the same test
        from tendyn.sim import catalogue
        test = catalogue.planned_test(lexos, catalogue.resolve(lexos, "constant-velocity",
                                                               {"transmission": 2, "strategy": strategy}))
        rq, rv, _ = cv_references(Gm, test, m.dt)
        np.testing.assert_array_equal(ref.stack(prefix), rq)
        assert len(ref.meta["options"]["poses"]) == 2    # two loads by default
        # every pass stays inside the joint limits
        q = ref.stack(prefix) if strategy == "S2" else ref.stack(prefix) @ np.linalg.inv(Gm).T
        lims = np.array([[j.lower, j.upper] for j in lexos.kinematics.joints])
        assert np.all(q >= lims[:, 0] - 1e-9) and np.all(q <= lims[:, 1] + 1e-9)
        held = ref.meta["options"]["held_motors" if strategy == "S1" else "held_joints"]
        assert held == [1, 3, 4]
    with pytest.raises(SystemExit):
        _parse(["plan", "constant-velocity", "lexos", "--transmission", "0", "--out", str(out)])
    with pytest.raises(UsageError, match="must be 1…4"):
        s0.run_plan(_parse(["plan", "constant-velocity", "lexos", "--transmission", "5", "--out", str(out)]))


def test_identify_friction_and_decompose_commands(comparison, tmp_path, capsys):
    from tendyn.commands import s0

    cmp, runs = comparison
    paths = []
    for t in range(1, 5):
        paths.append(str(write_log(runs[(t, "S2")].log, tmp_path / f"t{t}.parquet")))
    out = tmp_path / "friction.json"
    assert s0.run_identify_friction(_parse(["identify-friction", "lexos", *paths, "--out", str(out), "--json"])) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["coulomb_motor"][1] == pytest.approx(cmp.fits[(2, "S2")].coulomb_motor)
    assert all(f["strategy"] == "S2" and f["residual_bound"] is not None for f in doc["fits"])
    assert doc["fits"][3]["residual_bound"] == 0.0
    assert s0.run_decompose(_parse(["decompose", "lexos", str(out), "--json"])) == 0
    dec = json.loads(capsys.readouterr().out)
    assert dec["max_relative_mismatch"] < 1e-12 and len(dec["transmissions"][3]["tau0_branch"]) == 4
    with pytest.raises(UsageError, match="no constant-velocity log for transmission 4"):
        s0.run_identify_friction(_parse(["identify-friction", "lexos", *paths[:3], "--out", str(out)]))


def test_ident_imports_no_simulator_and_reads_no_truth():
    """DESIGN: ident/ imports device/, io/ and the core, never sim/; an estimator never reads a twin's truth."""
    import pathlib

    import tendyn.ident

    for path in pathlib.Path(tendyn.ident.__file__).parent.glob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert "tendyn.sim" not in text and "read_truth" not in text and "truth_path" not in text, path.name


def test_cli_main_runs_the_commands_one_line_errors(comparison, tmp_path, capsys):
    """Through ``tendyn.cli.main`` (the commands are found by register()): a bad FRICTION.json is exit 2 with
    one line naming the field; a good run prints JSON."""
    from tendyn.cli import main

    cmp, runs = comparison
    paths = [str(write_log(runs[(t, "S2")].log, tmp_path / f"t{t}.csv")) for t in range(1, 5)]
    out = tmp_path / "friction.json"
    assert main(["identify-friction", "lexos", *paths, "--out", str(out)]) == 0
    assert "C_m0" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    doc["viscous_motor"][2] = float("nan")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    assert main(["decompose", "lexos", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "viscous_motor[3]: must be a finite number" in err and err.startswith("tendyn: error:")
    assert main(["plan", "constant-velocity", "lexos", "--transmission", "9", "--out", str(tmp_path / "r.csv")]) == 2
    assert "--transmission: must be 1…4" in capsys.readouterr().err
    assert main(["decompose", "lexos", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["max_relative_mismatch"] < 1e-12


def test_identify_friction_record_adds_the_fit_to_the_calibration_history(comparison, tmp_path, capsys):
    """`--record --db`: the identified C_m0 and ν of every transmission, with their σ, are in the history."""
    from tendyn.cli import main
    from tendyn.ident.history import history

    cmp, runs = comparison
    paths = [str(write_log(runs[(t, "S2")].log, tmp_path / f"t{t}.parquet")) for t in range(1, 5)]
    db = tmp_path / "history.sqlite"
    out = tmp_path / "friction.json"
    assert main(["identify-friction", "lexos", *paths, "--out", str(out), "--record", "--db", str(db)]) == 0
    doc = json.loads(out.read_text())
    rows = {r["name"]: r for r in history(load_device(bundled("lexos")), db=db).rows}
    assert len(rows) == 8
    assert rows["C_m0[2]"]["value"] == doc["coulomb_motor"][1]
    assert rows["nu[4]"]["sigma"] == doc["fits"][3]["viscous_motor_std"]


def test_negative_friction_is_refused_by_decompose_not_split_into_negative_branches(friction_doc, tmp_path, capsys):
    """A FRICTION.json with a negative Coulomb value was decomposed into τ0 = −6.25 N (issue 22): decompose (and
    maps) read it with physical=True: exit 2, one line naming the field."""
    from tendyn.cli import main

    doc = json.loads(json.dumps(friction_doc))
    doc["coulomb_motor"][1] = doc["fits"][1]["coulomb_motor"] = -0.05
    bad = tmp_path / "negative.json"
    bad.write_text(json.dumps(doc))
    assert main(["decompose", "lexos", str(bad), "--json"]) == 2
    cap = capsys.readouterr()
    err = cap.err.strip().splitlines()
    assert len(err) == 1 and "negative.json" in err[0] and "coulomb_motor[2]: must be >= 0" in err[0] and not cap.out
