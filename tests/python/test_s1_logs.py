"""Issue 21, item 4: S1 from the logs a bench records (pipelines/s1_logs.py) and the bench plans of `tendyn plan`.

The estimators read only the logs (force_cmd → force_tendon); the truth they are compared with is the twin's
linear plant G(s) (S1 eq. 2, analysis/s1_plant) and its node friction (device fields), never passed to them."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

control = pytest.importorskip("control")

from tendyn.analysis.s1_plant import PlantParams, TendonDrivePlant  # noqa: E402
from tendyn.cli import main  # noqa: E402
from tendyn.device.tendon_bench import load_tendon_bench  # noqa: E402
from tendyn.devices import bundled  # noqa: E402
from tendyn.io import read_log  # noqa: E402
from tendyn.pipelines import s1_logs  # noqa: E402
from tendyn.sim import tendon_bench as tb  # noqa: E402

FREQS = np.arange(6.0, 46.0, 4.0)


@pytest.fixture(scope="module")
def mcgill():
    return load_tendon_bench(bundled("mcgill_bench"))


def route(bench):
    G = TendonDrivePlant(PlantParams.from_bench(bench)).tf()
    summary, fit, wiener, logs = s1_logs.s1_from_logs(bench, freqs_hz=FREQS, large_amplitude_N=2.0, truth_G=G,
                                                      dead_band_truth_N=2 * bench.friction_at_rest)
    return summary, fit, wiener, logs, G


@pytest.fixture(scope="module")
def mcgill_route(mcgill):
    return route(mcgill)


def test_route_recovers_G_and_no_dead_band_on_a_frictionless_bench(mcgill):
    """A generated bench without node friction is linear (at the PRBS levels, no slack): the Wiener model's
    linear block, made continuous, is G(s) within 5 % from 2 to 20 Hz and its dead-band vanishes. Guards the
    log alignment (u_{k+1}, y_k) and the inverse zero-order hold."""
    bench = mcgill.replace(friction_c0=0.0, friction_mu_tension=0.0, name="frictionless bench")
    summary, _, wiener, _, G = route(bench)
    assert summary["wiener"]["linear_max_rel_error_in_band"] < 0.05
    assert wiener.params["width"] < 0.01
    assert max(wiener.validation_nrms) < 0.05
    assert summary["lure"]["linear_max_rel_error_in_band"] < 0.05       # no friction to feed back
    assert summary["lure"]["dead_band_N"] < 0.01 and max(summary["lure"]["validation_nrms"]) < 0.05


def test_C21_C24_dead_band_from_the_mcgill_twins_prbs_logs(mcgill_route):
    """The McGill twin: a Wiener model (G then dead-zone, S1 Fig. 8) fitted by output error on PRBS logs at
    0.5, 1 and 2 N has a dead-band half-width within 10 % of the twin's 2 F_c (F_c = F_c0 + μ_T T_pre), and
    predicts the 1.5 N validation log (simulation from rest) with NRMS < 0.2. Not general: see
    test_dead_band_from_prbs_logs_on_generated_benches."""
    summary, _, wiener, logs, _ = mcgill_route
    assert summary["wiener"]["dead_band_rel_error"] < 0.10
    assert wiener.validation_nrms[1] < 0.2
    assert {lg.meta["experiment"] for lg in logs["prbs"]} == {"prbs"}


@pytest.mark.parametrize("changes", [{"friction_c0": 0.2, "friction_mu_tension": 0.01},
                                     {"friction_c0": 0.05, "mass_motor": 0.3, "k1": 4e4, "pretension": 8.0},
                                     {"damping_motor": 30.0}])
def test_C21_dead_band_from_prbs_logs_on_generated_benches(mcgill, changes):
    """C21 on benches the McGill file does not describe (2 F_c = 0.5, 0.18, 0.25 N; other mass, stiffness,
    pretension, damping): the Lur'e model (G(z) with Coulomb friction in its feedback, the twin's node
    friction inside the dynamics) fitted by output error to the PRBS logs gives the dead-band half-width
    within 10 % of 2 F_c (F_c = F_c0 + μ_T T_pre) and G(s) within 5 % from 2 to 20 Hz. The Wiener dead-zone
    does not (measured: 0.67 N for 0.5 N, 0.013 N for 0.18 N, 0.010 N for 0.25 N with 3x damping): the
    friction is not a static dead-band after G."""
    summary = route(mcgill.replace(**changes))[0]
    assert summary["lure"]["dead_band_rel_error"] < 0.10
    assert summary["lure"]["linear_max_rel_error_in_band"] < 0.05
    assert summary["lure"]["validation_nrms"][1] < 0.1             # the 1.5 N validation log, from rest


def test_C21_linear_block_within_5_percent_of_G_on_the_mcgill_twin(mcgill_route):
    """C21, issue 21 item 5: on the McGill twin the Lur'e model's linear block, made continuous, is G(s)
    (S1 eq. 2) within 5 % from 2 to 20 Hz, and its friction level — the dead-band's half-width — is the
    twin's 2 F_c within 10 %; it predicts both validation logs (0.4 and 1.5 N, from rest) with NRMS < 0.1.
    The Wiener model of the same logs cannot (its G absorbs the friction that acts inside the dynamics:
    measured max error 2-20 Hz, one level per fit, 42 % at 0.5 N, 14.8 % at 1 N, 6.3 % at 2 N; the three
    levels together 10.7 %)."""
    summary = mcgill_route[0]
    assert summary["lure"]["linear_max_rel_error_in_band"] < 0.05
    assert summary["lure"]["dead_band_rel_error"] < 0.10
    assert max(summary["lure"]["validation_nrms"]) < 0.1
    assert summary["wiener"]["linear_max_rel_error_in_band"] > 0.05      # the Wiener model's G is not G(s)


def test_C24_plant_fit_from_stepped_sine_logs_and_loop_area_from_the_low_speed_log(mcgill, mcgill_route):
    """Ĝ_L from the 2 N stepped-sine logs (tone H1) peaks near the 30 Hz resonance with G(0) ≈ 1 within 10 %
    below 20 Hz; the loop area read from the 0.2 Hz / 0.31 N log equals the one of the in-memory low-speed
    record (tendon_bench.loop_io, another code path, every step)."""
    summary, fit, _, logs, G = mcgill_route
    assert 27 <= fit.freq_hz <= 33
    assert summary["plant_fit"]["max_rel_error_vs_G_in_band"] < 0.1
    assert summary["frf"]["coherence_min"] > 0.99
    ref = tb.loop_io(mcgill, None, freq_hz=0.2, amplitude_N=0.31, cycles=1, settle_cycles=1, decimate=1)
    from tendyn.pipelines.s1 import loop_area

    assert summary["loop_area"] == pytest.approx(loop_area(ref.u, ref.force), abs=2e-3)
    assert 0.3 < summary["loop_area"] < 0.8              # a dead-band with a hysteresis-like loop (C21, C24)


# ---- tendyn plan prbs | multisine | stepped-sine -------------------------------------------------------------

def run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_plan_prbs_levels_and_clock(tmp_path):
    code, out, err = run(["plan", "prbs", "mcgill_bench", "--amplitude", "1.5", "--duration", "4", "--clock", "50",
                          "--bits", "6", "--out", str(tmp_path / "p.csv"), "--json"])
    assert code == 0, err
    log = read_log(tmp_path / "p.csv")
    u = log["force_cmd"]
    assert set(np.unique(u)) == {-1.5, 1.5} and log.n_samples == 4000
    changes = np.flatnonzero(np.diff(u)) + 1
    assert np.all(changes % 20 == 0)                   # a level lasts whole 20 ms clock periods at 1 kHz
    period = 63 * 20                                    # 2⁶ − 1 clock periods
    np.testing.assert_array_equal(u[:period], u[period:2 * period])
    assert u[:period].sum() / 20 == pytest.approx(1.5)  # a maximum-length sequence: one more +1 than −1
    assert json.loads(out)["logs"][0]["samples"] == 4000


def test_plan_multisine_lines_in_band_and_peak(tmp_path):
    code, _, err = run(["plan", "multisine", "--amplitude", "2", "--duration", "4", "--band", "3,40", "--period", "2",
                        "--name", "voltage", "--unit", "V", "--out", str(tmp_path / "m.parquet")])
    assert code == 0, err
    log = read_log(tmp_path / "m.parquet")
    assert log.units["input_1"] == "V" and log.resolve("voltage") == "input_1"
    u = log["input_1"]
    assert np.max(np.abs(u)) == pytest.approx(2.0)
    U = np.abs(np.fft.rfft(u[:2000]))                   # one period: lines on the 0.5 Hz bins
    f = np.fft.rfftfreq(2000, 1e-3)
    lines = U > 1e-6 * U.max()
    assert f[lines].min() == pytest.approx(3.0) and f[lines].max() == pytest.approx(40.0)
    assert lines.sum() == 75 and np.ptp(U[lines]) < 1e-6 * U.max()


def test_plan_stepped_sine_one_log_per_frequency_read_back_by_frf(tmp_path):
    code, _, err = run(["plan", "stepped-sine", "mcgill_bench", "--amplitude", "0.5", "--frequencies", "5,12.5",
                        "--cycles", "6", "--out", str(tmp_path / "s.csv")])
    assert code == 0, err
    from tendyn.ident.frf import tone_frequency

    for k, f in enumerate((5.0, 12.5)):
        log = read_log(tmp_path / f"s_{k + 1:02d}.csv")
        assert log.meta["options"]["freq_hz"] == f
        assert tone_frequency(log["force_cmd"], 1000.0) == pytest.approx(f, rel=2e-3)


@pytest.mark.parametrize("argv, problem", [
    (["plan", "prbs", "mcgill_bench", "--duration", "1"], "--amplitude: required for `plan prbs`"),
    (["plan", "prbs", "--amplitude", "1", "--duration", "1"], "--name: required"),
    (["plan", "multisine", "mcgill_bench", "--amplitude", "1", "--duration", "1", "--band", "40,3"], "band_hz"),
    (["plan", "prbs", "lexos", "--amplitude", "1", "--duration", "1"], "give a tendon bench"),
    (["plan", "constant-velocity", "lexos"], "--transmission: required"),
])
def test_plan_usage_errors(tmp_path, argv, problem):
    code, _, err = run(argv + ["--out", str(tmp_path / "r.csv")])
    assert code == 2 and problem in err, err
    assert not (tmp_path / "r.csv").exists()


def test_pipeline_s1_given_a_log_points_to_the_log_commands(tmp_path):
    """Issue 21: `tendyn pipeline s1 LOG` used to fail with a TOML syntax error."""
    code, _, err = run(["pipeline", "s1", str(tmp_path / "bench.csv")])
    assert code == 2 and "is a log" in err and "tendyn identify-bench" in err


def test_simulate_prbs_on_the_tendon_bench_feeds_identify_bench(tmp_path):
    """Issue 21: `tendyn simulate mcgill_bench prbs` (an experiment of the catalogue's table) writes a PRBS log:
    two levels ±torque changing only on the clock's 20 ms ticks, the register from --seed (another seed,
    another sequence), the same command as excitation.prbs; its clock is checked against the log rate."""
    from tendyn.sim.excitation import prbs

    code, _, err = run(["simulate", "mcgill_bench", "prbs", "--torque", "1.5", "--duration", "3", "--seed", "4",
                        "--out", str(tmp_path / "p.csv"), "--quiet"])
    assert code == 0, err
    log = read_log(tmp_path / "p.csv")
    u = log["force_cmd"]
    assert log.meta["experiment"] == "prbs" and log.meta["options"]["clock_hz"] == 50.0
    assert set(np.unique(u)) == {-1.5, 1.5} and log.n_samples == 3000
    assert np.all((np.flatnonzero(np.diff(u)) + 1) % 20 == 0)
    np.testing.assert_array_equal(u, prbs(1.5, 3.0, 20000.0, clock_hz=50.0, seed=4)[19::20])
    assert np.std(log["force_tendon"]) > 0.1                 # the bench moved
    code, _, err = run(["simulate", "mcgill_bench", "prbs", "--torque", "1", "--duration", "1", "--clock", "800",
                        "--out", str(tmp_path / "q.csv")])
    assert code == 2 and "--clock" in err and not (tmp_path / "q.csv").exists()
