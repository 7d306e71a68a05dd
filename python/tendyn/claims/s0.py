"""S0 (tendon transmissions, L-EXOS): C1–C12. Oracles: closed forms written here, numpy, Pinocchio."""

from __future__ import annotations

import numpy as np

from tendyn.claims import twins
from tendyn.claims.core import claim
from tendyn.claims.routings import random_routing


@claim("C1", "S0", "forward/inverse transmission kinematics R_m q_m = K q round-trip; K lower-triangular",
       "round trip to machine precision", "|error| ≤ 1e-12 rad on seeded random routings of 1–7 joints",
       quick="cheaper", tests=("test_routing.py::test_C1_round_trip_random_routings",))
def c1(ctx, v):
    rng, worst, sizes = ctx.rng(), 0.0, set()
    for _ in range(ctx.count):
        tr = random_routing(rng)
        sizes.add(tr.n)
        K = tr.K
        v.that(np.array_equal(K, np.tril(K)), "K lower-triangular for a serial routing")
        q_m = rng.uniform(-np.pi, np.pi, tr.n)
        worst = max(worst, np.abs(tr.motor_from_joint(tr.joint_from_motor(q_m)) - q_m).max())
        q = rng.uniform(-np.pi, np.pi, tr.n)
        worst = max(worst, np.abs(tr.joint_from_motor(tr.motor_from_joint(q)) - q).max())
        # R_m q_m = K q, the compact form of S0 eqs. 1–2
        worst = max(worst, np.abs(np.diag(tr.model.motor_radius) @ tr.motor_from_joint(q) - K @ q).max())
    v.that(worst <= 1e-12, f"round-trip error {worst:.2e} > 1e-12")
    v.that(sizes == set(range(1, 8)) or ctx.count < 100, f"routing sizes {sorted(sizes)} miss some of 1–7")
    return f"max error {worst:.1e} ({ctx.count} routings)"


@claim("C2", "S0", "generalised radius with integrated reducer r_i^i = r_pulley n_i", "r_i^i = r_pulley n_i",
       "identity (1e-12); L-EXOS K_11 = 0.04 m × 8 = 0.32 m",
       tests=("test_device_file.py::test_C2_generalized_radius_is_pulley_times_reducer",))
def c2(ctx, v):
    dev = twins.lexos(ctx)
    K = dev.routing_arrays()["K"]
    for i, t in enumerate(dev.transmissions):
        v.close(t.generalized_radius, t.driven_radius * t.reducer_ratio, rel=1e-12, what=f"r_{i + 1} = r n")
        v.close(K[i, i], t.generalized_radius, rel=1e-12, what=f"K_{i + 1}{i + 1}")
    v.close(np.diag(K), [0.32, 0.32, 0.09, 0.24], rel=1e-9, what="diag K [m]")
    v.close(np.diag(K) / dev.routing_arrays()["motor_radius"], [40, 40, 11.25, 30], rel=1e-9,
            what="joint/motor ratios (DEVICES.md)")
    return "K_ii = " + ", ".join(f"{k:.3g}" for k in np.diag(K)) + " m"


@claim("C3", "S0", "lossless statics τ_J = Kᵀ t, C_m = R_m t; virtual work q̇ᵀ τ_J = q̇_mᵀ C_m",
       "virtual work balances", "|q̇ᵀτ_J − q̇_mᵀC_m| ≤ 1e-12 (relative) on seeded random routings",
       quick="cheaper", tests=("test_routing.py::test_C3_lossless_virtual_work",))
def c3(ctx, v):
    rng, worst = ctx.rng(), 0.0
    for _ in range(ctx.count):
        tr = random_routing(rng)
        qd = rng.normal(size=tr.n)
        qd_m = tr.motor_from_joint(qd)          # same linear map as positions
        tau = rng.normal(size=tr.n)
        cm = tr.feedforward(tau, losses=False).torque_motor
        worst = max(worst, abs(qd @ tau - qd_m @ cm) / max(1.0, abs(qd @ tau)))
        cm = rng.normal(size=tr.n)
        tj = tr.forward(cm, losses=False).torque_joint
        worst = max(worst, abs(qd @ tj - qd_m @ cm) / max(1.0, abs(qd_m @ cm)))
        t = cm / np.array(tr.model.motor_radius)           # tensions R_m⁻¹ C_m, and τ_J = Kᵀ t
        worst = max(worst, np.abs(tj - tr.K.T @ t).max())
    v.that(worst <= 1e-12, f"virtual-work mismatch {worst:.2e} > 1e-12")
    return f"max mismatch {worst:.1e} ({ctx.count} routings)"


def _one_joint(**kw):
    from tendyn.transmission import Transmission

    # motor pulley 10 mm, driven pulley 50 mm, no reducer: ratio 5
    return Transmission.from_arrays([0.01], [[0.05]], **kw)


@claim("C4", "S0", "tension loss Δτ = β τ sgn(Ṡ) + ν Ṡ (and the τ_0 form); drop follows power flow; stuck case",
       "Δτ = τ0 sgn(Ṡ) + ν Ṡ", "identity (1e-12) on a one-joint routing; stuck below break-away",
       tests=("test_losses.py::test_C4_tau0_form_and_direction_of_power_flow",))
def c4(ctx, v):
    tau0, nu, t_joint = 1.5, 10.0, 40.0                  # N, N·s/m, N wanted at the driven pulley
    tr = _one_joint(tau0=[[tau0]], nu=[[nu]])
    got = []
    for qd in (2.0, -2.0):
        sdot = 0.05 * qd
        t_m = tr.feedforward([t_joint * 0.05], [qd]).tension_motor[0]
        got.append(t_m)
        v.close(t_m, t_joint + tau0 * np.sign(sdot) + nu * sdot, rel=1e-12, what=f"motor tension at q̇ = {qd}")
    v.that(got[0] > t_joint > got[1], "the drop must reverse with the power flow (driving vs back-driven)")
    stuck = _one_joint(tau0=[[2.0]])
    weak = stuck.forward([0.01 * 1.5], [0.0])            # 1.5 N < 2 N break-away
    v.that(weak.stuck[0, 0] and weak.torque_joint[0] == 0.0, "a branch at rest below break-away passes nothing")
    strong = stuck.forward([0.01 * 5.0], [0.0])          # 5 N: passes 3 N
    v.that(not strong.stuck[0, 0], "5 N breaks a 2 N branch away")
    v.close(strong.torque_joint[0], 3.0 * 0.05, rel=1e-12, what="torque passed above break-away [N·m]")
    return f"motor tension {got[0]:.2f} N driving / {got[1]:.2f} N back-driven for 40 N at the joint"


@claim("C5", "S0", "bearing law (eqs. 7–8): static below α p, β p + h(n) moving, h0 below n0, h1 n^(2/3) above",
       "eqs. 7–8", "identity on every branch of the law", tests=("test_losses.py::test_C5_bearing_law_every_branch",))
def c5(ctx, v):
    from tendyn import _core

    alpha, beta, h0, h1, n0, p = 2e-3, 1.5e-3, 1e-3, 2e-4, 5.0, 100.0
    law = lambda speed, applied: _core.bearing_friction_torque(alpha, beta, h0, h1, n0, p, speed, applied)  # noqa: E731
    t, stuck = law(0.0, 0.1)
    v.that(stuck and t == 0.1, "holds 0.1 N·m < α p = 0.2 N·m")
    t, stuck = law(0.0, 0.17)
    v.that(stuck and t == 0.17, "β p = 0.15 < 0.17 < α p: only α holds it")
    t, stuck = law(0.0, -0.3)
    v.that(not stuck, "breaks away above α p")
    v.close(t, -(beta * p + h0), rel=1e-12, what="break-away torque")
    v.close(law(2.0, 0.0)[0], beta * p + h0, rel=1e-12, what="slow: h0")
    fast = law(-27.0, 0.0)[0]
    v.close(fast, -(beta * p + h1 * 27.0 ** (2 / 3)), rel=1e-12, what="fast: h1 n^(2/3), opposing")
    v.close(_core.bearing_speed_term(h0, h1, n0, 8.0), h1 * 4.0, rel=1e-12, what="h(8) = h1 8^(2/3)")
    return f"α p = {alpha * p:.3g} N·m static; {fast:+.4g} N·m at −27 rad/s"


@claim("C6", "S0", "reducer: η_d driving, 1/η_i back-driven, η_i = (2η_d − 1)/η_d; η_d ≤ 0.5 self-locking",
       "η_d = 0.9 → η_i = 0.8889; η_d ≤ 0.5 self-locking", "η_i within 5e-5 of 0.8889; torques to 1e-12",
       tests=("test_losses.py::test_C6_reducer_efficiencies",))
def c6(ctx, v):
    from tendyn import _core
    from tendyn.transmission import Transmission

    eta_i = _core.reducer_inverse_efficiency(0.9)
    v.close(eta_i, 0.8889, abs_=5e-5, what="η_i(0.9)")
    v.close(eta_i, 8 / 9, rel=1e-15, what="η_i(0.9) = 8/9")
    v.that(_core.reducer_self_locking(0.5) and _core.reducer_self_locking(0.3), "η_d ≤ 0.5 self-locks")
    v.that(not _core.reducer_self_locking(0.51), "η_d = 0.51 does not self-lock")
    tr = Transmission.from_arrays([0.008], [[0.32]], reducer_ratio=[8.0], reducer_efficiency=[0.9])
    v.close(tr.feedforward([1.0], [1.0]).torque_motor[0], 0.008 / 0.04 / (8 * 0.9), rel=1e-12, what="driving")
    v.close(tr.feedforward([1.0], [-1.0]).torque_motor[0], 0.008 / 0.04 * (8 / 9) / 8, rel=1e-12, what="back-driven")
    locked = Transmission.from_arrays([0.008], [[0.32]], reducer_ratio=[8.0], reducer_efficiency=[0.4])
    res = locked.feedforward([1.0], [-1.0])
    v.that(res.status == _core.Status.SelfLocked and res.torque_motor[0] == 0.0, "η_d = 0.4 holds a back-driving load")
    return f"η_i = {eta_i:.4f}; η_d = 0.4 self-locked"


@claim("C7", "S0", "constant-velocity identification C_m = C_m0 sgn(q̇_m) + ν q̇_m per transmission (S1, S2)",
       "C_m0 and ν per transmission", "S2 fits of transmissions 2 and 4 within 5 % (C_m0) and 10 % (ν) of the twin",
       tests=("test_ident_friction.py::test_C7_twin_logs_recover_the_truth",))
def c7(ctx, v):
    cmp, _ = twins.friction_comparison(ctx)
    parts = []
    for t in (2, 4):
        ec, ev = cmp.errors_pct(t, "S2")
        v.that(abs(ec) < 5 and abs(ev) < 10, f"transmission {t}: C_m0 error {ec:+.1f} %, ν error {ev:+.1f} %")
        parts.append(f"t{t}: C_m0 {ec:+.1f} %, ν {ev:+.1f} %")
    return "; ".join(parts)


@claim("C8", "S0", "on the twin S2 identifies every transmission with smaller error than S1",
       "S2 error < S1 error", "transmissions 1–3: S2 < S1; transmission 4 (same experiment): |S1 − S2| < 1e-4 N·m",
       tests=("test_ident_friction.py::test_C8_S2_smaller_error_than_S1",))
def c8(ctx, v):
    cmp, _ = twins.friction_comparison(ctx)
    parts = []
    for t in (1, 2, 3):
        e1, e2 = cmp.torque_error(t, "S1"), cmp.torque_error(t, "S2")
        v.that(e2 < e1, f"transmission {t}: S2 {e2:.2e} ≥ S1 {e1:.2e} N·m")
        parts.append(f"t{t} {1e3 * e1:.2f}→{1e3 * e2:.2f}")
    e1, e2 = cmp.torque_error(4, "S1"), cmp.torque_error(4, "S2")
    v.that(abs(e1 - e2) < 0.1e-3 and e2 < 0.5e-3, f"transmission 4: S1 {e1:.2e}, S2 {e2:.2e} N·m")
    return "S1→S2 rms error [mN·m]: " + ", ".join(parts)


@claim("C9", "S0", "loss decomposition ν^i = Σ ν_j k'_j², C_m0^i = Σ τ_0,j |k'_j|, shares sum to 1",
       "reproduces the global values exactly", "relative mismatch < 1e-12 (default and random shares)",
       tests=("test_ident_friction.py::test_C9_decomposition_reproduces_the_global_values_exactly",))
def c9(ctx, v):
    from tendyn.ident import decompose

    cmp, _ = twins.friction_comparison(ctx)
    dev = twins.lexos(ctx)
    c0 = [cmp.fits[(t, "S2")].coulomb_motor for t in range(1, 5)]
    nu = [cmp.fits[(t, "S2")].viscous_motor for t in range(1, 5)]
    m1 = decompose(dev, c0, nu).max_mismatch()
    p = np.tril(np.random.default_rng(3).random((4, 4)))
    p /= p.sum(axis=1, keepdims=True)
    m2 = decompose(dev, c0, nu, p, p).max_mismatch()
    v.that(m1 < 1e-12 and m2 < 1e-12, f"mismatch {m1:.1e} (default shares), {m2:.1e} (random shares)")
    return f"max mismatch {max(m1, m2):.1e}"


def compensator_oracle(lexos, comp, q_motor, qd_motor, torque_joint, k, band):
    """Independent route to a compensator cycle: Pinocchio gravity + the Python statics with losses
    (Transmission.feedforward), friction part scaled by k and faded in the velocity band [rad/s]."""
    import pinocchio as pin

    tr = lexos.transmission
    M = tr.matrices()
    q = M["joint_from_motor_position"] @ q_motor
    # the joint velocity the core derived from qd_motor: a motor at rest gives branch velocities at round-off
    # level whose sign decides the Coulomb term, so both routes must see the same qd
    qd = np.array(comp.data.qd)
    g = pin.computeGeneralizedGravity(lexos.pinocchio_model, lexos.pinocchio_data(), q)
    tau = torque_joint + g
    c0 = tr.feedforward(tau, losses=False).torque_motor
    cff = tr.feedforward(tau, qd).torque_motor
    w = np.minimum(1.0, np.abs(qd_motor) / band) if band > 0 else np.ones(len(q_motor))
    return c0 + k * w * (cff - c0), M["joint_from_motor_position"] @ qd_motor, qd


@claim("C10", "S0", "rendering law; X̂ from motor encoders; feedforward β(q̄) = friction + gravity",
       "feedforward = friction + gravity", "compensator cycle = Pinocchio gravity + Python statics with losses "
       "to 1e-12 N·m on 100 random inputs (k = 0.7, band 5 rad/s)",
       tests=("test_compensator.py::test_C10_compensator_equals_python_statics_with_losses_on_random_inputs",))
def c10(ctx, v):
    from tendyn.control import Compensator

    lx = twins.lexos_compiled(ctx)
    worst = 0.0
    for k, band in ((1.0, 0.0), (0.7, 5.0), (1.3, 0.0)):
        comp = Compensator.from_device(lx, underestimation=k, velocity_band=band, velocity_cutoff_hz=0.0)
        rate = comp.model.rate_hz
        rng = np.random.default_rng(13)
        for _ in range(100):
            comp.reset()
            qm0 = rng.uniform(-20, 20, size=4)
            qd_motor = rng.normal(scale=8.0, size=4)
            qd_motor[rng.random(4) < 0.2] = 0.0            # some motors at rest
            qm1 = qm0 + qd_motor / rate
            tj = rng.normal(scale=2.0, size=4)
            comp.cycle(qm0, tj)
            got = comp.cycle(qm1, tj)
            qd_est = np.array(comp.data.qd_motor)
            v.close(qd_est, (qm1 - qm0) * rate, abs_=1e-9, what="motor speed from encoders")
            want, qd_ref, qd_core = compensator_oracle(lx, comp, qm1, qd_est, tj, k, band)
            v.close(qd_core, qd_ref, rel=1e-12, abs_=1e-12, what="joint speed")
            worst = max(worst, np.abs(got - want).max() / max(1.0, np.abs(want).max()))
    v.that(worst <= 1e-12, f"compensator vs oracle {worst:.1e}")
    v.failed[:] = list(dict.fromkeys(v.failed))[:5]
    return f"max difference {worst:.1e} (relative)"


@claim("C11", "S0", "active compensation cuts the joint-1 torque the hand needs by > 50 % vs gravity only",
       "> 50 %", "reduction > 50 % (k = 0.9, seed 7); gravity-only RMS > 0.05 N·m",
       tests=("test_fig7.py::test_C11_active_compensation_cuts_the_joint1_hand_torque_by_more_than_half",))
def c11(ctx, v):
    f = twins.fig7(ctx)
    r = f.reduction_joint1
    v.that(r > 0.5, f"reduction {100 * r:.1f} % ≤ 50 %")
    v.that(f.gravity_only.rms_joint1 > 0.05, "friction to compensate (gravity-only RMS > 0.05 N·m)")
    return f"{100 * r:.1f} % reduction"


@claim("C12", "S0", "the paper's hypotheses as switches (sensors, static friction, efficiencies)",
       "C11 holds under S0's hypotheses", "C11 (> 50 %) and passivity (≤ 1e-3 J per cycle) with each switch flipped",
       tests=("test_s0_hypotheses.py::test_C12_C11_holds_under_every_setting_and_each_stays_passive",))
def c12(ctx, v):
    res = twins.hypotheses(ctx)
    parts = []
    for _, flipped, run in res.runs:
        r = res.reduction(run)
        v.that(r > 0.5, f"{flipped or 'S0'}: reduction {100 * r:.1f} %")
        v.that(run.energy_to_hand_per_cycle <= 1e-3, f"{flipped or 'S0'}: {run.energy_to_hand_per_cycle:.2e} J/cycle")
        parts.append(f"{flipped or 'S0'} {100 * r:.0f} %")
    return ", ".join(parts)
