"""dVRK MTM real data (../shared/external-data/dvrk_mtm, no licence: read there, never copied) and the sweep fit of
`tendyn identify-term` (issue 29, MTM part).

* TermFit / identify-term on a generated sweep: a known polynomial (numpy's polyval, the test's truth) plus
  a Coulomb friction by direction and noise; the coefficients within 4 σ, the curve within 1e-3 N·m.
* identify-term on the real sweep: tendyn's curve against WPI's published polynomial.
* WPI's metric on trajectory `two`: tendyn's defaults at or below WPI on every joint; WPI's own published
  parameters (params.json) through tendyn's model, `wpi` treatment and metric within 5 % of WPI's per-joint errors
  (measured within 3.2 %: the treatment, model and metric are WPI's; plants: the frames' rotations left out or
  transposed, 33-9 700 % off, -m slow); the `wpi` preset's own fit within 5 % (not reached: xfail, strict, with
  the measured numbers — WPI's published point is an unconverged SCS iterate outside WPI's own boxes); WPI's own
  problem shape (test_wpi_sdp_is_wpi_problem_shape) and, with WPI's solver built (`make scs126`) and `-m slow`,
  the preset with WPI's boxes, form and SCS 1.2.6 within 5 % (test_wpi_preset_with_wpi_solver_within_5_percent).
Two real fits (6000 samples, consistent SDP) take about 7 s together, once per module: the reason this module
is over 5 s.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("TENDYN_SHARED", REPO.parent / "shared"))
MTM = SHARED / "external-data" / "dvrk_mtm"
needs_data = pytest.mark.skipif(not (MTM / "one_results.csv").is_file(),
                                reason=f"the dVRK MTM data are not at {MTM} (../shared/external-data/dvrk_mtm)")


@functools.lru_cache(maxsize=None)
def _bench(name):
    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / "realdata" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(spec.origin and Path(spec.origin).parent))
    spec.loader.exec_module(mod)
    return mod


TRUTH = np.array([0.004, 0.05, -0.02, -0.015, 0.006])      # N·m/rad^k, k = 0..4 (the test's polynomial)


def _sweep(rng, n=4000, friction=0.07, noise=0.003):
    q = np.concatenate([np.linspace(-1.4, 3.3, n // 2), np.linspace(3.3, -1.4, n // 2)])
    qd = np.concatenate([np.full(n // 2, 0.4), np.full(n // 2, -0.4)])
    qd[:50] = np.linspace(0, 0.4, 50)                     # the start: slow samples the fit must leave out
    tau = np.polyval(TRUTH[::-1], q) + friction * np.sign(qd) + noise * rng.normal(size=n)
    return q, qd, tau


def test_term_fit_recovers_a_generated_polynomial():
    from tendyn.ident.term_fit import TermFit

    q, qd, tau = _sweep(np.random.default_rng(4))
    f = TermFit("polynomial", 4).fit(q, qd, tau)
    assert np.all(np.abs(f.coef_ - TRUTH) < 4 * f.stderr_), (f.coef_, f.stderr_)
    grid = np.linspace(-1.4, 3.3, 50)
    assert np.max(np.abs(f.predict(grid) - np.polyval(TRUTH[::-1], grid))) < 1e-3
    assert abs(f.friction_ - 0.07) < 4 * f.friction_stderr_
    t = TermFit("table", knots=30).fit(q, qd, tau)             # the table kind: the same curve
    assert np.max(np.abs(t.predict(grid) - np.polyval(TRUTH[::-1], grid))) < 2e-3


def test_term_fit_refuses_a_one_way_sweep():
    from tendyn.ident.lsq import IdentificationError
    from tendyn.ident.term_fit import TermFit

    q, qd, tau = _sweep(np.random.default_rng(1))
    with pytest.raises(IdentificationError, match="both ways"):
        TermFit().fit(q[:1500], qd[:1500], tau[:1500])


def _run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tendyn.cli", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=120)


def test_identify_term_writes_a_known_term_the_device_loads(tmp_path):
    from tendyn.device import load_device
    from tendyn.device.terms import TermModel
    from tendyn.device.compiled import compile_device
    from tendyn.io import make_log, write_log

    dev = _bench("mtm_device").write_mtm_device(tmp_path)           # public geometry only
    q, qd, tau = _sweep(np.random.default_rng(2))
    log = make_log({"time": np.arange(q.size) / 200.0, "q_joint_6": q, "qd_joint_6": qd, "torque_motor_4": tau},
                   device="dvrk_mtm", rate_hz=200.0, seed=2, experiment="sweep")
    write_log(log, tmp_path / "sweep.csv")
    r = _run("identify-term", dev, "sweep.csv", "--joint", 6, "--order", 4, "--out", "new.toml", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    new = load_device(tmp_path / "new.toml")
    term = [t for t in new.terms if t.name == "cable6"][0]
    assert term.kind == "known" and term.joint == 6
    tm = TermModel(compile_device(new))
    qa = np.zeros((5, 7)); qa[:, 3] = np.linspace(-1, 3, 5)
    assert np.allclose(tm.known(qa)[:, 3], np.polyval(TRUTH[::-1], qa[:, 3]), atol=2e-3)
    assert np.allclose(np.delete(tm.known(qa), 3, axis=1), 0.0)
    bad = _run("identify-term", dev, "sweep.csv", "--joint", 5, cwd=tmp_path)     # a passive joint
    assert bad.returncode == 2 and bad.stderr.startswith("tendyn: error:") and "--joint" in bad.stderr
    assert "Traceback" not in bad.stderr


@needs_data
def test_identify_term_on_the_real_sweep_matches_wpi_curve():
    from tendyn.ident.term_fit import TermFit

    mtm = _bench("mtm")
    d = np.loadtxt(MTM / "joint4_cable_sweep.csv", delimiter=",")
    f = TermFit("polynomial", 7).fit(d[:, 0], d[:, 1], d[:, 2])
    grid = np.linspace(*f.range_, 400)
    wpi = np.polyval(mtm.WPI_CABLE, grid)
    diff = f.predict(grid) - wpi
    # measured: max 0.0117 N·m, RMS 0.0031 N·m over a 0.214 N·m range; tendyn's residual 0.0058 vs WPI's 0.0066
    assert np.max(np.abs(diff)) < 0.015 and np.sqrt(np.mean(diff ** 2)) < 0.005
    assert f.score(d[:, 0], d[:, 1], d[:, 2]) <= 0.0066
    assert f.curve_stderr_ < 0.002


@pytest.fixture(scope="module")
def mtm_errors():
    if not (MTM / "one_results.csv").is_file():
        pytest.skip(f"the dVRK MTM data are not at {MTM}")
    return _bench("mtm").errors(SHARED)


@needs_data
def test_defaults_at_or_below_wpi_on_every_joint(mtm_errors):
    e, w = mtm_errors["default"], mtm_errors["wpi"]
    assert np.all(e <= w), f"tendyn default {np.round(e, 4)} vs WPI {w}"


@needs_data
def test_wpi_published_parameters_through_tendyn_within_5_percent(mtm_errors):
    """WPI's params.json predicted by tendyn (wpi treatment, WPI's cable, WPI's metric) gives WPI's published
    per-joint errors: measured [0.0753 0.1475 0.1646 0.2262 0.2770 0.2341 0.3428], within 3.2 %."""
    e, w = mtm_errors["wpi_params"], mtm_errors["wpi"]
    assert np.all(np.abs(e / w - 1) <= 0.05), f"WPI's parameters through tendyn {np.round(e, 4)} vs WPI {w}"


@needs_data
@pytest.mark.slow
@pytest.mark.parametrize("plant", ["identity", "transposed"])
def test_wpi_published_parameters_plants_are_seen(plant, monkeypatch):
    """The frames' rotations at q = 0 (WPI writes its parameters in the base frame's orientation) left out or
    transposed: some joint > 5 % off (measured: 33 % to 9 700 %)."""
    mtm = _bench("mtm")
    orig = mtm._rotations_at_zero
    fake = {"identity": lambda: {j: np.eye(3) for j in orig()}, "transposed": lambda: {j: r.T for j, r in orig().items()}}
    monkeypatch.setattr(mtm, "_rotations_at_zero", fake[plant])
    mtm.errors.cache_clear()
    try:
        e = mtm.errors(SHARED)
    finally:
        mtm.errors.cache_clear()
    assert np.max(np.abs(e["wpi_params"] / e["wpi"] - 1)) > 0.05


@needs_data
def test_wpi_published_point_is_outside_wpi_boxes():
    """Why no converged fit reproduces WPI's numbers: their published parameters (an SCS iterate stopped at
    10 000 iterations, primal residual 4.9e-2 in their notebook's log) break their own SDP's bounds and the
    physical consistency it was to enforce: motor 4's inertia < 0 (bound ≥ 0.001 kg·m²), viscous frictions of
    joints 5 and 7 below their 0.001 minimum, link 5's inertia about its centre of mass with a negative trace."""
    import json

    mtm = _bench("mtm")
    P = json.loads((MTM / "params.json").read_text())
    assert P["10"]["Im"] < 0 < mtm.WPI_MIN_ROTOR
    assert P["7"]["Fv"] < mtm.WPI_MIN_FRICTION and P["9"]["Fv"] < mtm.WPI_MIN_FRICTION
    i7 = P["7"]["I"]
    assert i7[0] + i7[3] + i7[5] < 0


@needs_data
@pytest.mark.xfail(strict=True, reason="measured preset wpi (consistent, no boxes) [0.0716 0.1459 0.1766 0.2385 "
                   "0.2570 0.2312 0.3338]: joints 1 (-7 %), 4 (+7 %), 5 (-8 %) outside 5 %; with WPI's boxes solved "
                   "to convergence [0.0752 0.1540 0.1833 0.2666 0.3575 0.4038 2.82] (WPI's published point is outside "
                   "its own boxes); WPI's own parameters through tendyn are within 3.2 %: the solver, not the "
                   "treatment, is what differs (docs/realdata.md)")
def test_wpi_preset_within_5_percent(mtm_errors):
    e, w = mtm_errors["preset"], mtm_errors["wpi"]
    assert np.all(np.abs(e / w - 1) <= 0.05), f"preset {np.round(e, 4)} vs WPI {w}"


SCS126 = REPO / "build" / "scs126" / "venv" / "bin" / "python"


@needs_data
def test_wpi_sdp_is_wpi_problem_shape():
    """The SDP tendyn builds for WPI's problem (the wpi preset on `one`, WPI's 63 boxes, WPI's form) has the shape
    of WPI's as SCS logged it (cell 95): the same 39 195-entry second-order cone (39 193 weighted rows + 2: the
    rows of the treatment are WPI's), the same 9 PSD blocks of 4 × 4; 118 variables where WPI has 123 (5 friction
    parameters fewer: frames with one velocity share theirs in tendyn, 2 Fc/Fv, 3 offsets) and one linear row per
    bound side, 125 (WPI 136, 10 of them on those 5 parameters)."""
    mtm = _bench("mtm")
    size = mtm.wpi_sdp_shape(SHARED)
    w = mtm.WPI_SOLVER_INFO
    assert size["soc"] == [w["soc"]] and size["psd"] == [4] * w["psd_blocks"], size
    assert size["variables"] == w["variables"] - 5 and size["boxes"] == 63, size
    assert size["linear"] == 2 * 63 - 1 and size["zero"] == 0, size
    assert size["constraints"] == size["linear"] + w["soc"] + w["psd_vars"], size


@needs_data
@pytest.mark.slow
@pytest.mark.skipif(not SCS126.is_file(), reason="WPI's solver is not built: `make scs126` (SCS 1.2.6 in "
                    "build/scs126, benchmarks/realdata/build_scs126.sh)")
def test_wpi_preset_with_wpi_solver_within_5_percent(request):
    """The wpi preset with WPI's boxes, WPI's form and WPI's solver (SCS 1.2.6: CG, eps 1e-3, alpha 1.5, 10 000
    iterations) reproduces WPI's run: SCS's final primal residual within 2 % of WPI's logged 4.898e-2 and WPI's
    per-joint errors within 5 % each (the issue's target, which the converged fits miss: see
    test_wpi_preset_within_5_percent). 10 000 SCS iterations with CG on 39 410 rows: 872 s to 24 min on a shared
    core, so it runs only when asked (`pytest -m slow`), like the long fuzz."""
    if "slow" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("WPI's solver runs 10 000 iterations (15-25 min): run with -m slow")
    mtm = _bench("mtm")
    r = mtm.wpi_solver_errors(SHARED, SCS126)
    w = np.array(mtm.WPI_ERRORS)
    assert r["scs"]["iter"] == 10000 and abs(r["scs"]["res_pri"] / mtm.WPI_SOLVER_INFO["residual"] - 1) < 0.02, r["scs"]
    assert np.all(np.abs(r["errors"] / w - 1) <= 0.05), f"WPI's solver {np.round(r['errors'], 4)} vs WPI {w}"


@needs_data
def test_wpi_preset_close_to_wpi(mtm_errors):
    """What the preset reaches today: within 10 % on every joint (a wrong cut-off unit fails it)."""
    e, w = mtm_errors["preset"], mtm_errors["wpi"]
    assert np.all(np.abs(e / w - 1) <= 0.10), f"preset {np.round(e, 4)} vs WPI {w}"


@needs_data
def test_rows_contract(mtm_errors):
    rows = _bench("mtm").rows(SHARED, bounded=False)
    assert len(rows) == 7
    assert set(rows[0]) == {"dataset", "peer", "metric", "item", "peer_value", "tendyn_preset", "tendyn_default",
                            "unit", "wpi_params_through_tendyn", "tendyn_preset_wpi_bounds",
                            "tendyn_preset_wpi_bounds_wpi_cable", "tendyn_preset_wpi_solver"}
    assert rows[0]["metric"] == "relative error on two"


@needs_data
@pytest.mark.slow
def test_preset_with_wpi_boxes_converged_is_far_from_wpi():
    """WPI's boxes met (Clarabel, converged): the wrist joints far above WPI's published errors (measured joint 7
    2.82 vs 0.340: the 0.001 N·m·s/rad viscous minimum on the wrist roll, whose torques span 0.006 N·m)."""
    b = _bench("mtm").bounded_errors(SHARED)
    w = np.array(_bench("mtm").WPI_ERRORS)
    for cable in ("tendyn", "wpi"):
        assert b[cable][6] > 2 * w[6] and np.all(b[cable][:3] < 1.2 * w[:3]), b
