"""S2 (identification of the CEA branch): C29–C46. The estimators read the twin's logs only; the truth they are
compared with (its file's standard parameters, regrouped numerically) is read here only."""

from __future__ import annotations

import numpy as np

from tendyn.claims import twins
from tendyn.claims.core import claim

# S2's list of 29 minimum parameters (§V.D) in tendyn's names; the twin has MY4 too (handle-support first moment)
S2_BASE = {"ZZ1R", "MX1", "MY1R", "FV1", "FS1", "OFFSET1", "XX2R", "XY2R", "XZ2R", "YZ2R", "ZZ2R", "MX2R", "MY2",
           "FV2", "FS2", "OFFSET2", "XX3R", "XY3R", "XZ3R", "YZ3R", "ZZ3R", "MX3R", "MY3R", "MX5R", "MY5", "FV5",
           "FS5", "OFFSET5", "MY6"}
INERTIAL = ("ZZ1R", "MY1R", "ZZ2R", "MX2R", "ZZ3R", "MX3R")   # XX2R, XX3R: the C38:XX expected failure


def _table4_rel(ctx) -> dict:
    return {r["name"]: r["rel_stderr_pct_at_paper_rows"] for r in twins.s2_report(ctx).summary["table4"]}


@claim("C29", "S2", "IDIM Γ = D x_b; LS with σ̂² = ‖Y − WX̂‖²/(r − b), C = σ̂²(WᵀW)⁻¹, %σ = 100 σ/|x̂|",
       "σ̂² and σ(x̂) of eq. (LS)", "σ̂² within 10 % of the known noise variance 0.01; σ(x̂) within 15 % of √(σ²/r)",
       tests=("test_ident.py::test_sigma2_uses_the_squared_norm",))
def c29(ctx, v):
    from tendyn.ident import least_squares

    rng = np.random.default_rng(3)
    W = rng.normal(size=(4000, 5))
    Y = W @ np.arange(1.0, 6.0) + 0.1 * rng.normal(size=4000)       # σ = 0.1 → σ² = 0.01
    x, se, s2, _ = least_squares(W, Y)
    v.close(s2, 0.01, rel=0.1, what="σ̂²")
    v.close(se, np.full(5, np.sqrt(0.01 / 4000)), rel=0.15, what="σ(x̂)")
    v.close(x, np.arange(1.0, 6.0), abs_=5 * np.sqrt(0.01 / 4000), what="x̂ within 5σ")
    return f"σ̂² = {s2:.4f} (truth 0.01)"


@claim("C30", "S2", "parallelogram constraints and Lᵀ (eqs. 8–12)", "Lᵀ of eq. 12", "the twin's constraint map "
       "equals eqs. 8–11 written here (sympy Jacobian) exactly",
       tests=("test_cea_branch.py::test_C30_constraint_map_equals_eqs_8_to_11",))
def c30(ctx, v):
    import sympy as sp

    from tendyn.device.closed_loop import active_coordinate_map

    active, L, c = active_coordinate_map(twins.cea(ctx))
    v.that(active == [0, 1, 4], f"active joints {active} ≠ q1, q2, q5")
    q1, q2, q5 = qa = sp.symbols("q1 q2 q5")
    qp = sp.Matrix([q5 - q2, q2 - q5, sp.pi / 2 - q5])          # q3, q6, q4 of eqs. 8–11
    dqp = np.array(qp.jacobian(sp.Matrix(qa)), dtype=float)
    rows = [2, 5, 3]                                            # tree indices of q3, q6, q4
    v.that(np.array_equal(L[rows], dqp), "passive rows ≠ eqs. 8–11")
    v.that(np.array_equal(L[rows].T, [[0, 0, 0], [-1, 1, 0], [1, -1, -1]]), "Lᵀ ≠ printed eq. 12")
    v.that(np.array_equal(L[6], [0, -1, 1]), "q7 = q3 (eq. 10)")
    v.that(np.array_equal(L[active], np.eye(3)), "active rows = identity")
    v.close(c, [0, 0, 0, np.pi / 2, 0, 0, 0], abs_=1e-15, what="offsets")
    return "Lᵀ = [[0,0,0],[−1,1,0],[1,−1,−1]] (passive q3, q6, q4)"


@claim("C31", "S2", "capstan stiffness K1 = K2 = K5 = 2.0 N·m/rad (rel. dev. 0.3–0.5 %), blocked test, hysteresis",
       "2.0 N·m/rad, %σ 0.3–0.5", "K within 2 % of the twin's K_T per drive, %σ < 1 %, loop width 2 F_c ± 30 %",
       tests=("test_s2_ident.py::test_C31_capstan_stiffness_per_drive",))
def c31(ctx, v):
    rows = twins.s2_report(ctx).summary["stiffness"]
    drives = twins.cea(ctx).drives
    v.that([r["drive"] for r in rows] == [d.joint for d in drives], "one stiffness per drive")
    for r, d in zip(rows, drives):
        v.close(r["K"], d.stiffness_motor, rel=0.02, what=f"K{d.joint} [N·m/rad]")
        v.that(r["rel_stderr_pct"] < 1.0, f"K{d.joint} %σ {r['rel_stderr_pct']:.2f}")
        v.close(r["hysteresis_width_Nm"], 2 * d.coulomb_motor, rel=0.3, what=f"hysteresis width {d.joint} [N·m]")
    return ", ".join(f"K{r['drive']} = {r['K']:.3f} ({r['rel_stderr_pct']:.2f} %)" for r in rows)


@claim("C32", "S2", "bandwidth ≈ 20 Hz; identification band 0.1–2 Hz", "≈ 20 Hz; 0.1–2 Hz",
       "bandwidth 15–25 Hz; band 0.1 Hz – bandwidth/10; IDIM cut-offs below the bandwidth",
       tests=("test_s2_ident.py::test_C32_bandwidth_and_identification_band",))
def c32(ctx, v):
    s = twins.s2_report(ctx).summary
    lo, hi = s["identification_band_hz"]
    v.that(15.0 < s["bandwidth_hz"] < 25.0, f"bandwidth {s['bandwidth_hz']:.1f} Hz")
    v.close([lo, hi], [0.1, s["bandwidth_hz"] / 10], rel=1e-9, what="identification band [Hz]")
    v.that(s["treatment"]["parallel_cutoff_hz"] < s["bandwidth_hz"] / 2, "parallel cut-off < bandwidth/2")
    v.that(s["treatment"]["cutoff_hz"] < s["bandwidth_hz"], "cut-off < bandwidth")
    return f"bandwidth {s['bandwidth_hz']:.1f} Hz; band {lo:g}–{hi:.2f} Hz"


@claim("C33", "S2", "viscous + Coulomb suffices at low velocity on this device", "Table 3 model",
       "every Table 3 coefficient within 3σ (+1 %) of the twin's joint-side friction",
       tests=("test_s2_ident.py::test_C33_C35_friction_table3",))
def c33(ctx, v):
    rows = {r["name"]: r for r in twins.s2_report(ctx).summary["friction"]["table3"]}
    drive = {d.joint: d for d in twins.cea(ctx).drives}
    worst = 0.0
    for name in ("FV1", "FC1", "FV2t1", "FC2t1", "FV2t2", "FC2t2", "FV5t1", "FC5t1", "FV5t3", "FC5t3"):
        d = drive[int(name[2])]
        truth = d.viscous_joint if name.startswith("FV") else d.coulomb_joint
        r = rows[name]
        z = abs(r["value"] - truth) / r["stderr"]
        worst = max(worst, z)
        v.that(abs(r["value"] - truth) < 3 * r["stderr"] + 0.01 * truth, f"{name}: {r['value']:.4g} vs {truth:.4g}")
    return f"worst |error| {worst:.1f}σ over 10 coefficients"


@claim("C34", "S2", "t1/t2/t3: F_V2t1 ≈ F_V2t2, F_C2t1 ≈ F_C2t2, F_V5t1 ≈ F_V5t3, F_C5t1 ≈ F_C5t3 → passive ≈ 0",
       "passive-joint friction ≈ 0", "every t1 − t2/t3 difference |z| < 3; decision 'negligible'",
       tests=("test_s2_ident.py::test_C34_passive_joint_friction_negligible",))
def c34(ctx, v):
    dec = twins.s2_report(ctx).summary["friction"]["passive_joints"]
    zs = {k: d["z"] for k, d in dec["differences"].items()}
    v.that(dec["passive_friction_negligible"], "decision: passive friction not negligible")
    v.that(all(abs(z) < 3 for z in zs.values()), f"differences {zs}")
    return f"max |z| = {max(abs(z) for z in zs.values()):.2f}"


@claim("C35", "S2", "cond(W) ≈ 6 in the friction tests; viscous coefficients with large %σ (9–20 %)",
       "cond(W) ≈ 6", "cond(W) of every friction test 3–12; %σ FV < 25 %, FC < 2 %",
       tests=("test_s2_ident.py::test_C33_C35_friction_table3",))
def c35(ctx, v):
    s = twins.s2_report(ctx).summary
    conds = s["cond_friction"]
    v.that(all(3.0 < c < 12.0 for c in conds.values()), f"cond(W) {conds}")
    rows = s["friction"]["table3"]
    for r in rows:
        v.that(r["rel_stderr_pct"] < (25.0 if r["name"].startswith("FV") else 2.0), f"{r['name']} %σ {r['rel_stderr_pct']:.1f}")
    fv = [r["rel_stderr_pct"] for r in rows if r["name"].startswith("FV")]
    return f"cond(W) {min(conds.values()):.1f}–{max(conds.values()):.1f}; %σ FV {min(fv):.1f}–{max(fv):.1f}"


@claim("C36", "S2", "29 minimum parameters; ²J_R2 = ²J_2 + ⁶J_6, ³J_R3 = ³J_3 + ⁵J_5; link 4 into link 1",
       "29 base parameters", "rank 30 = S2's 29 + MY4 (clear numerical gap > 1e6); the regroupings' coefficients 1",
       tests=("test_cea_branch.py::test_C36_rank_and_base_set",))
def c36(ctx, v):
    from tendyn.device.closed_loop import base_parameters

    b = ctx.get("cea_base", lambda: base_parameters(twins.cea(ctx), n_samples=120, seed=7))
    sv = b.singular_values
    v.that(b.rank == 30 == len(b.names), f"rank {b.rank}")
    v.that(sv[29] > 1e6 * sv[30], "numerical gap at the rank")
    v.that(set(b.names) == S2_BASE | {"MY4"}, f"base set differs: {sorted(set(b.names) ^ (S2_BASE | {'MY4'}))}")
    for comp in ("XY", "YZ", "ZZ", "XZ"):
        v.close([b.terms(f"{comp}2R")[f"{comp}6"], b.terms(f"{comp}3R")[f"{comp}5"]], [1.0, 1.0], rel=1e-6,
                what=f"{comp}: ²J_R2 = ²J_2 + ⁶J_6, ³J_R3 = ³J_3 + ⁵J_5")
    for comp in ("XX", "XY", "XZ", "YY", "YZ", "ZZ"):
        users = [n for n in b.names if f"{comp}4" in b.terms(n)]
        v.that(users in ([], ["ZZ1R"]), f"link 4's {comp}4 reaches {users}")
    return f"{b.rank} base parameters (S2's 29 + MY4)"


@claim("C37", "S2", "W 15000 × 16 and cond(W) ≈ 50 with triangular + sinusoidal exciting trajectories",
       "cond(W) ≈ 50", "cond(W) of the Table 4 model 10–100; full model's > 5×; optimisation does not worsen it",
       tests=("test_s2_ident.py::test_C37_exciting_trajectory_cond",))
def c37(ctx, v):
    s = twins.s2_report(ctx).summary
    v.that(10.0 < s["cond_exciting"] < 100.0, f"cond(W) {s['cond_exciting']:.1f}")
    v.that(s["cond_full"] > 5 * s["cond_exciting"], f"full model's cond {s['cond_full']:.1f}")
    v.that(s["cond_design"]["after"] <= s["cond_design"]["before"], "phase optimisation made cond(W) worse")
    return f"cond(W) = {s['cond_exciting']:.1f} (full model {s['cond_full']:.0f})"


@claim("C38", "S2", "Table 4 values within ≈ 3σ; %σ of the paper's order (inertial < 1.5, Coulomb < 1.3, offsets 1–3)",
       "Table 4, within 3σ", "every parameter within 3σ of the twin; %σ at 15000 rows: inertial (but XX) < 1.5, "
       "Coulomb < 1.3, offsets 0.3–5, ZZ1R 0.3–0.65",
       tests=("test_s2_ident.py::test_C38_table4_within_3_sigma",
              "test_s2_ident.py::test_C38_relative_deviations_of_the_papers_order"))
def c38(ctx, v):
    truth = twins.s2_truth(ctx)
    worst = 0.0
    for r in twins.s2_report(ctx).summary["table4"]:
        x = truth[r["base_name"]]
        worst = max(worst, abs(r["identified"] - x) / r["stderr"])
        v.that(abs(r["identified"] - x) <= 3 * r["stderr"], f"{r['name']}: {r['identified']:.4g} vs {x:.4g}")
        v.that(r["within_3_sigma"] == (abs(r["identified"] - r["paper"]) <= 3 * r["stderr"]), "report flag")
    t4 = _table4_rel(ctx)
    for n in INERTIAL:
        v.that(t4[n] < 1.5, f"{n} %σ {t4[n]:.2f}")
    for n in ("FS1", "FS2", "FS5R"):
        v.that(t4[n] < 1.3, f"{n} %σ {t4[n]:.2f}")
    for n in ("OFFSET2", "OFFSET5"):
        v.that(0.3 < t4[n] < 5.0, f"{n} %σ {t4[n]:.2f}")
    v.that(0.3 < t4["ZZ1R"] < 0.65, f"ZZ1R %σ {t4['ZZ1R']:.2f}")
    return f"worst {worst:.1f}σ from the twin; %σ ZZ1R {t4['ZZ1R']:.2f}"


@claim("C38:XX", "S2", "inertial %σ < 1.5 for XX2R and XX3R too", "XX2R 0.85 %, XX3R 1.25 %", "%σ < 1.5 at 15000 rows",
       xfail="NOT REACHED: XX2R and XX3R come out at %σ ≈ 2.5 % at 15000 rows (S2: 0.85, 1.25 %): the XX columns "
             "(sin 2q, cos 2q terms) are weakly excited by the design's ranges",
       tests=("test_s2_ident.py::test_C38_XX_inertias_below_1p5_percent",))
def c38_xx(ctx, v):
    t4 = _table4_rel(ctx)
    v.that(t4["XX2R"] < 1.5 and t4["XX3R"] < 1.5, f"XX2R {t4['XX2R']:.2f} %, XX3R {t4['XX3R']:.2f} %")
    return f"%σ XX2R {t4['XX2R']:.2f}, XX3R {t4['XX3R']:.2f}"


@claim("C38:viscous", "S2", "viscous coefficients with %σ ≈ 20 %", "≈ 20 %", "%σ of FV1, FV2R, FV5R in 8–40 %",
       xfail="the twin's viscous friction is exactly linear and the exciting speeds span 0-1.5 rad/s: FV comes out at "
             "%σ 2-5 %, not the paper's ~20 % (S2's joints show no significant viscous friction, which the twin, "
             "built from Table 4, does not reproduce)",
       tests=("test_s2_ident.py::test_C38_viscous_relative_deviation_about_20_percent",))
def c38_viscous(ctx, v):
    t4 = _table4_rel(ctx)
    v.that(all(8.0 < t4[n] < 40.0 for n in ("FV1", "FV2R", "FV5R")), "FV %σ outside 8–40 %")
    return ", ".join(f"{n} {t4[n]:.1f} %" for n in ("FV1", "FV2R", "FV5R"))


@claim("C39", "S2", "omitted parameters have large %σ; removing them leaves the others unperturbed",
       "large %σ; others unperturbed", "14 omitted, each %σ > 30 %; Table 4 moves < 3σ without them",
       tests=("test_s2_ident.py::test_C39_omitted_parameters",))
def c39(ctx, v):
    s = twins.s2_report(ctx).summary
    om = s["omitted"]
    v.that(len(om) == 14, f"{len(om)} omitted parameters")
    v.that(all(o["rel_stderr_pct"] > 30.0 for o in om), "an omitted parameter has %σ ≤ 30 %")
    v.that(s["omitted_perturbation_max_sigma"] < 3.0, f"perturbation {s['omitted_perturbation_max_sigma']:.2f}σ")
    return f"min %σ omitted {min(o['rel_stderr_pct'] for o in om):.0f} %; others move ≤ {s['omitted_perturbation_max_sigma']:.2f}σ"


@claim("C40", "S2", "cross-validation on a trajectory not used for identification", "estimated follows measured",
       "relative error < 5 % per joint (1, 2, 5)", tests=("test_s2_ident.py::test_C40_cross_validation",))
def c40(ctx, v):
    cv = twins.s2_report(ctx).summary["crossval"]
    v.that(cv["joints"] == [1, 2, 5], f"joints {cv['joints']}")
    v.that(all(e < 0.05 for e in cv["rel_error"]), f"errors {cv['rel_error']}")
    return "relative error " + ", ".join(f"{100 * e:.1f} %" for e in cv["rel_error"])


@claim("C41", "S2", "M_op = J⁻ᵀAJ⁻¹, B_op, K_op = J⁻ᵀ(N²K_tot)J⁻¹, F_cop, F_d of ERRATA",
       "operational model", "M_op Ẍ + B_op Ẋ + F_cop sgn + F_d = J⁻ᵀ Γ (twin's RNEA + drive friction) to 1e-8 at 5 random poses",
       tests=("test_s2_maps.py::test_C41_operational_model_reproduces_inverse_dynamics_with_the_errata_Fd",))
def c41(ctx, v):
    from tendyn.device.closed_loop import active_dynamics

    m, cd, q0 = twins.operational_model(ctx), twins.cea_compiled(ctx), twins.natural_pose(ctx)
    L, c = cd.active_map
    rng, worst, poses = np.random.default_rng(5), 0.0, []
    while len(poses) < 5:
        q = q0 + rng.uniform(-0.5, 0.5, 3)
        if m.within_limits(q, margin=0.05):
            poses.append(q)
    for q in poses:
        qd, qdd = rng.normal(size=3), rng.normal(size=3)
        # the oracle: the twin's inverse dynamics (Pinocchio RNEA in active coordinates) + its drive friction
        gamma = active_dynamics(cd.pinocchio_model, L, c, q, qd, qdd)
        gamma += np.array([d.rotor_inertia_joint * a + d.viscous_joint * w + d.coulomb_joint * np.sign(w)
                           + d.offset_joint for d, w, a in zip(cd.device.drives, qd, qdd)])
        p = m.at(q)
        Xd, Xdd = p.J @ qd, p.J @ qdd + m.jdot_qd(q, qd)
        lhs = np.linalg.solve(p.J.T, gamma)
        fd = m.disturbance(q, qd)
        rhs = p.M @ Xdd + p.B @ Xd + p.Fc @ np.sign(qd) + fd
        worst = max(worst, np.linalg.norm(rhs - lhs) / np.linalg.norm(lhs))
        # the printed F_d (… − A q̈) misses by A J⁻¹ J̇ q̇ + A q̈
        printed = np.linalg.solve(p.J.T, m.gravity(q) + m.offsets() + m.coriolis(q, qd) - m.mass_matrix(q) @ qdd)
        v.that(np.linalg.norm(rhs - fd + printed - lhs) > 1e-3 * np.linalg.norm(lhs), "the printed F_d must fail")
    v.that(worst < 1e-8, f"operational model vs inverse dynamics {worst:.1e}")
    return f"max relative error {worst:.1e} (5 poses)"


@claim("C42", "S2", "maximum apparent mass ≈ 650 g around a natural pose, up to 800 g elsewhere (±30 %)",
       "up to 800 g elsewhere", "max over the ±50 mm grid in 560–1040 g, every grid point reachable",
       tests=("test_s2_maps.py::test_C42_max_apparent_mass_elsewhere_reaches_800_g",))
def c42(ctx, v):
    d = twins.maps(ctx).to_dict()
    v.that(d["grid"]["reachable"] == d["grid"]["points"], "unreachable grid points")
    v.that(0.8 * 0.7 <= d["max_apparent_mass_kg"] <= 0.8 * 1.3, f"{1e3 * d['max_apparent_mass_kg']:.0f} g")
    return f"max {1e3 * d['max_apparent_mass_kg']:.0f} g over the grid"


@claim("C42:natural", "S2", "maximum apparent mass ≈ 650 g at the natural pose", "650 g ± 30 %",
       "455–845 g at the natural pose",
       xfail="the twin's natural (isotropic) pose gives 447 g, 2 % under the 455 g lower end of 650 g ± 30 %; "
             "650 g is reached ~30 mm away (neighbourhood profile)",
       tests=("test_s2_maps.py::test_C42_max_apparent_mass_at_the_natural_pose_650_g",))
def c42_natural(ctx, v):
    m = twins.maps(ctx).natural["apparent_mass_kg"][0]
    v.that(0.65 * 0.7 <= m <= 0.65 * 1.3, f"{1e3 * m:.0f} g")
    return f"{1e3 * m:.0f} g at the natural pose"


@claim("C43", "S2", "operational stiffness 2000–5000 N/m", "2000–5000 N/m", "diagonal of K_op at the natural pose",
       tests=("test_s2_maps.py::test_C43_stiffness_at_the_natural_pose_in_2000_5000",))
def c43(ctx, v):
    k = twins.maps(ctx).natural["stiffness_diag_N_per_m"]
    v.that(all(2000.0 <= x <= 5000.0 for x in k), f"K_op diag {k}")
    return "K_op " + ", ".join(f"{x:.0f}" for x in k) + " N/m at the natural pose"


@claim("C43:grid", "S2", "operational stiffness 2000–5000 N/m over the workspace", "2000–5000 N/m",
       "K_op range over the ±50 mm grid",
       xfail="over the ±50 mm grid K_op spans 2930–7450 N/m: where the handle nears axis 1 or the elbow straightens, "
             "J shrinks and K = N² K_tot/σ² exceeds 5000",
       tests=("test_s2_maps.py::test_C43_stiffness_over_the_grid_in_2000_5000",))
def c43_grid(ctx, v):
    lo, hi = twins.maps(ctx).to_dict()["stiffness_range_N_per_m"]
    v.that(2000.0 <= lo and hi <= 5000.0, f"{lo:.0f}–{hi:.0f} N/m")
    return f"{lo:.0f}–{hi:.0f} N/m over the grid"


@claim("C44", "S2", "maximum operational dry friction 0.3–0.4 N (±30 %)", "0.3–0.4 N",
       "0.21–0.52 N at the natural pose and over the grid",
       tests=("test_s2_maps.py::test_C44_dry_friction_0p3_to_0p4_N",))
def c44(ctx, v):
    m = twins.maps(ctx)
    d = m.to_dict()
    lo, hi = 0.3 * 0.7, 0.4 * 1.3
    nat = m.natural["dry_friction_N"][0]
    v.that(lo <= nat <= hi, f"{nat:.3f} N at the natural pose")
    v.that(lo <= d["dry_friction_range_N"][0] and d["max_dry_friction_N"] <= hi,
           f"grid {d['dry_friction_range_N'][0]:.3f}–{d['max_dry_friction_N']:.3f} N")
    return f"{nat:.2f} N at the natural pose, ≤ {d['max_dry_friction_N']:.2f} N over the grid"


@claim("C45", "S2", "workspace > 200 mm in translation (full device; reported for the branch)", "> 200 mm",
       "reachable cube edge around the natural pose > 200 mm", tests=("test_s2_maps.py::test_C45_workspace_size_computed",))
def c45(ctx, v):
    from tendyn.analysis.operational import _workspace

    m, q = twins.operational_model(ctx), twins.natural_pose(ctx)
    ws = _workspace(m, q, m.position(q), n_cube=3, n_joint=9, tol=0.005)
    edge = ws["reachable_cube_edge_m"]
    v.that(edge > 0.2, f"cube edge {1e3 * edge:.0f} mm")
    v.that(all(e > edge for e in ws["extents_m"]), "extents larger than the cube")
    return f"reachable cube {1e3 * edge:.0f} mm"


@claim("C46", "S2", "friction compensation with under-estimated coefficients; gravity from identified parameters",
       "under-estimated, passive", "k = 0.8 leaves 15–30 % of the felt friction; passive and stable; gravity holds "
       "the handle (drift < 0.1 mm, > 10 mm without)",
       tests=("test_s2_maps.py::test_C46_underestimated_friction_leaves_a_fraction_of_the_felt_friction",))
def c46(ctx, v):
    s = twins.s2_compensation(ctx).summary
    k0, k8 = s["strokes"]
    v.close(k0["friction_felt_N"], k0["friction_predicted_N"], rel=0.1, what="felt friction, k = 0 [N]")
    v.that(0.3 < k0["friction_felt_N"] < 1.0, f"felt friction k = 0 {k0['friction_felt_N']:.3f} N")
    ratio = k8["friction_felt_N"] / k0["friction_felt_N"]
    v.that(0.15 < ratio < 0.3, f"k = 0.8 leaves {100 * ratio:.0f} %")
    v.close(k8["friction_felt_N"], k8["friction_predicted_N"], abs_=0.03, what="felt friction, k = 0.8 [N]")
    v.that(s["passive"] and s["stable"], "passive and stable")
    v.that(all(st["energy_to_hand_J"] < 0 for st in s["strokes"]), "energy to the hand < 0")
    hold = {h["compensated"]: h for h in s["hold"]}
    v.that(hold[True]["drift_m"] < 1e-4 < 1e-2 < hold[False]["drift_m"], "gravity compensation holds the handle")
    return f"k = 0.8 leaves {100 * ratio:.0f} % of {k0['friction_felt_N']:.2f} N; drift {1e3 * hold[True]['drift_m']:.3f} mm"
