"""S2 on the CEA branch twin, end to end (issue 10 items 1–5, 8): capstan stiffness and bandwidth (C31, C32),
friction protocol and passive joints (C33–C35), exciting trajectories and cond(W) (C37), Table 4 (C36, C38),
omitted parameters (C39), cross-validation (C40), `tendyn pipeline s2`.

One quick run of the pipeline (module fixture, ~40 s) feeds every test. The estimators read only the logs; the
twin's truth (its standard parameters regrouped by :func:`tendyn.device.closed_loop.base_parameters`, a route
independent of the identification model's) is read here only.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.claims import assert_claim, twins, xfail_reason
from tendyn.device import load_device
from tendyn.devices import bundled


@pytest.fixture(scope="module")
def device():
    return load_device(bundled("cea_branch"))


@pytest.fixture(scope="module")
def report(claims_ctx):
    """`run_s2(quick=True, seed=0)` on the CEA twin, once per session (tendyn.claims.twins.s2_report)."""
    return twins.s2_report(claims_ctx)


@pytest.fixture(scope="module")
def truth(claims_ctx):
    """Base parameters of the twin (its file's standard parameters, regrouped numerically)."""
    return twins.s2_truth(claims_ctx)




# ---- C31, C32 -------------------------------------------------------------------------------------------

def test_C31_capstan_stiffness_per_drive(report, claims_ctx):
    """Blocked links, triangular torques: K by LS on [dq_m, dq̇_m, 1] recovers the twin's K_T per drive with
    a small %σ (S2 Table 2: 2.0 N·m/rad, 0.3–0.5 %); the loop's width is twice the motor's dry friction."""
    assert_claim("C31", claims_ctx)
    assert report.stiffness_motor == [r["K"] for r in report.summary["stiffness"]]
    fig = report.figures["hysteresis_joint2"].plot()
    assert fig.axes[0].get_xlabel().startswith("motor angle")


def test_C31_stiffness_fit_on_a_known_line():
    """The fit itself: a synthetic log τ = K dq + B dq̇ + off (+ noise) returns K, B, off within their σ."""
    from tendyn.io.logs import make_log
    from tendyn.pipelines.s2_stiffness import fit_capstan_stiffness

    rng = np.random.default_rng(4)
    t = np.arange(6000) / 1000.0
    q = 0.05 * np.sin(2 * np.pi * 0.5 * t)
    tau = 2.5 * q + 0.01 * 2 * np.pi * 0.5 * 0.05 * np.cos(2 * np.pi * 0.5 * t) + 0.003 + rng.normal(0, 1e-3, t.size)
    log = make_log({"time": t, "q_motor_1": q, "torque_motor_1": tau}, device="x", rate_hz=1000.0, seed=0,
                   experiment="blocked_link")
    fit = fit_capstan_stiffness(log, 1)
    assert abs(fit.K - 2.5) < 4 * fit.stderr[0] and abs(fit.offset - 0.003) < 4 * fit.stderr[2] + 1e-4
    assert fit.rel_stderr_pct[0] < 0.5


def test_C32_bandwidth_and_identification_band(claims_ctx):
    """K with the CAD inertia gives the ≈ 20 Hz bandwidth, and the identification band 0.1–2 Hz a decade
    below it; the treatment that IDIM used keeps the capstan resonance out of W (parallel cut-off < bw / 2)."""
    assert_claim("C32", claims_ctx)


# ---- C33–C35 --------------------------------------------------------------------------------------------

def test_C33_C35_friction_table3(claims_ctx):
    """Viscous + Coulomb per joint from constant-speed tests recovers the twin's joint-side friction
    (F_C = N C_m, F_V = N² ν) within 3σ (+1 % for the stick-slip of the motor); cond(W) ≈ 6 (S2)."""
    assert_claim("C33", claims_ctx)
    assert_claim("C35", claims_ctx)


def test_C34_passive_joint_friction_negligible(claims_ctx):
    """t1 vs t2 (joint 2) and t1 vs t3 (joint 5) agree: every difference |z| < 3, so F_V3R = F_C3R = 0."""
    assert_claim("C34", claims_ctx)


def test_C34_the_decision_can_fail():
    """A passive-joint Coulomb friction of 5σ in t2 and t3 is detected."""
    from tendyn.pipelines.s2_friction import passive_friction_test

    base = {k: {"value": v, "stderr": 0.001} for k, v in
            {"FV2t1": 0.03, "FV2t2": 0.03, "FC2t1": 0.12, "FC2t2": 0.12, "FV5t1": 0.03, "FV5t3": 0.03,
             "FC5t1": 0.12, "FC5t3": 0.12}.items()}
    assert passive_friction_test(base)["passive_friction_negligible"]
    bad = dict(base, FC2t2={"value": 0.12 + 0.0071, "stderr": 0.001})
    assert not passive_friction_test(bad)["passive_friction_negligible"]


# ---- C37 ------------------------------------------------------------------------------------------------

def test_C37_exciting_trajectory_cond(report, device, claims_ctx):
    """Triangles + sines inside the band, joint and passive-joint limits: cond(W) of the Table 4 model ≈ 50
    (paper), far below the full 30-parameter model's; the phase optimisation does not make it worse."""
    assert_claim("C37", claims_ctx)
    s = report.summary
    from tendyn.sim.experiments import ExcitingDesign, tree_limits

    d = s["exciting_design"]
    design = ExcitingDesign(**{k: (np.asarray(v) if isinstance(v, list) else v) for k, v in d.items()})
    q, qd, _ = design.references(90.0, 0.01)
    lo, hi, L, c = tree_limits(device)
    qt = q @ L.T + c
    assert np.all(qt >= lo) and np.all(qt <= hi)          # passive joints too
    assert np.abs(qd).max() <= 1.5 + 1e-6
    f = np.concatenate([design.sin_freq_hz.ravel(), design.tri_freq_hz])
    assert f.min() >= 0.1 and f.max() <= s["identification_band_hz"][1] + 1e-9
    assert len(set(np.round(design.sin_freq_hz.ravel(), 6))) == design.sin_freq_hz.size


# ---- C36, C38, C39 --------------------------------------------------------------------------------------

def test_C36_names_as_in_the_paper(report):
    from tendyn.pipelines.s2 import TABLE4_PAPER

    names = [r["name"] for r in report.summary["table4"]]
    assert names == list(TABLE4_PAPER)
    full = [p["paper_name"] for p in report.summary["params_full"]]
    s2_list = ["ZZ1R", "MX1", "MY1R", "FV1", "FS1", "OFFSET1", "XX2R", "XY2R", "XZ2R", "YZ2R", "ZZ2R", "MX2R",
               "MY2", "FV2", "FS2", "OFFSET2", "XX3R", "XY3R", "XZ3R", "YZ3R", "ZZ3R", "MX3R", "MY3", "MX5R", "MY5",
               "FV5R", "FS5R", "OFFSET5", "MY6"]
    assert set(s2_list) <= set(full) and len(full) == 30        # S2's 29 + MY4 of the twin
    for p in report.summary["params"]:
        assert set(p) >= {"name", "value", "stderr", "rel_stderr_pct", "unit", "expression"}


def test_C38_table4_within_3_sigma(claims_ctx):
    """Every Table 4 parameter is recovered within 3σ of the twin's value, and the report's flag agrees."""
    assert_claim("C38", claims_ctx)


def test_C38_relative_deviations_of_the_papers_order(claims_ctx):
    """At the paper's W length (15000 rows): inertial %σ < 1.5, Coulomb < 1.3, offsets 0.3–5 %; %σ(ZZ1R) near
    the paper's 0.45 % (the current noise of the twin is calibrated for it, docs/s2.md)."""
    assert_claim("C38", claims_ctx)


@pytest.mark.xfail(strict=True, reason=xfail_reason("C38:XX"))
def test_C38_XX_inertias_below_1p5_percent(claims_ctx):
    assert_claim("C38:XX", claims_ctx)


@pytest.mark.xfail(strict=True, reason=xfail_reason("C38:viscous"))
def test_C38_viscous_relative_deviation_about_20_percent(claims_ctx):
    assert_claim("C38:viscous", claims_ctx)


def test_C39_omitted_parameters(claims_ctx):
    """The parameters S2 omits have a large %σ when identified, and removing them moves the Table 4 ones by
    less than 3σ."""
    assert_claim("C39", claims_ctx)


# ---- C40 ------------------------------------------------------------------------------------------------

def test_C40_cross_validation(report, claims_ctx):
    """On a trajectory not used for the fit, the estimated torque follows the measured one (< 5 % per joint)."""
    assert_claim("C40", claims_ctx)
    fig = report.figures["crossval"].plot()
    assert "Fig. 7" in fig.axes[0].get_title()


# ---- the command ----------------------------------------------------------------------------------------

def test_pipeline_s2_command_json(report, capsys, monkeypatch, tmp_path):
    """`tendyn pipeline s2 --json --report DIR` prints the contract keys and writes the figures (the run
    itself is the module's, passed through run_s2)."""
    import tendyn.pipelines.s2 as s2
    from tendyn.cli import main

    monkeypatch.setattr(s2, "run_s2", lambda dev, quick=False, progress=None: report)
    code = main(["pipeline", "s2", "--quick", "--json", "--report", str(tmp_path / "rep")])
    assert code in (0, None)
    doc = json.loads(capsys.readouterr().out)
    for key in ("stiffness", "cond_exciting", "params", "table4", "stiffness_motor_Nm_per_rad"):
        assert key in doc
    assert {"drive", "K", "rel_stderr_pct"} <= set(doc["stiffness"][0])
    assert {"name", "paper", "identified", "rel_stderr_pct", "within_3_sigma"} <= set(doc["table4"][0])
    assert (tmp_path / "rep" / "crossval.png").exists() and (tmp_path / "rep" / "s2.json").exists()
    maps = doc["maps"]
    assert {"max_apparent_mass_kg", "stiffness_range_N_per_m", "max_dry_friction_N"} <= set(maps)
    assert len(maps["stiffness_range_N_per_m"]) == 2
    assert (tmp_path / "rep" / "maps_fig8.png").exists() and (tmp_path / "rep" / "compensation.png").exists()


def test_C41_C46_pipeline_maps_and_compensation_come_from_the_identified_values(report):
    """The maps and the C46 compensation of the pipeline are computed from what it identified — the Table 4
    parameters and the blocked-link stiffness — not from the twin's truth; they land in the bands of C42–C44
    where the twin's true parameters do (the bands the twin misses are xfails in test_s2_maps.py)."""
    s = report.summary
    maps = s["maps"]
    assert maps["params"] == "identified"
    np.testing.assert_allclose(maps["stiffness_motor_N_m_per_rad"], s["stiffness_motor_Nm_per_rad"], rtol=1e-12)
    assert 0.8 * 0.56 <= maps["max_apparent_mass_kg"] <= 1.3 * 0.8        # C42: up to 800 g ± 30 %
    assert 0.3 * 0.7 <= maps["max_dry_friction_N"] <= 0.4 * 1.3           # C44
    lo, hi = maps["stiffness_range_N_per_m"]
    assert 1000 < lo < hi < 10000                                          # C43 order (band: xfail there)
    comp = s["compensation"]
    assert comp["params"] == "identified"
    felt = {st["factor"]: st["friction_felt_N"] for st in comp["strokes"]}
    assert felt[0.0] > felt[0.5] > felt[0.8] > 0.0                         # C46: under-estimated → some left
    assert comp["stable"] and comp["gravity_holds"]


def test_pipeline_s2_refuses_a_device_without_drives(capsys):
    from tendyn.cli import main

    code = main(["pipeline", "s2", "lexos", "--json"])
    assert code == 2
    assert "device" in capsys.readouterr().err


def test_identify_parameters_option(tmp_path, capsys):
    """`tendyn identify --parameters` fits the named base parameters only (S2's reduced model); an unknown name
    is a usage error naming the option."""
    from tendyn.cli import main

    log = tmp_path / "ex.parquet"
    assert main(["simulate", "cea_branch", "exciting", "--duration", "8", "--out", str(log), "--quiet"]) == 0
    capsys.readouterr()
    names = "ZZ1R,MY1R,FS1,FS2,FS5,MX2R,MX3R,OFFSET2,OFFSET5"
    assert main(["identify", "cea_branch", str(log), "--parameters", names, "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [p["name"] for p in doc["params"]] == names.split(",")
    assert main(["identify", "cea_branch", str(log), "--parameters", "ZZ1R,BOGUS", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--parameters" in err and "BOGUS" in err
