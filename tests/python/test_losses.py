"""Statics with friction losses (S0 eqs. 6–13, corrected: ERRATA). Claims C4–C6."""

import numpy as np
import pytest

from routing_cases import random_routing
from tendyn import _core
from tendyn.claims import assert_claim
from tendyn.transmission import Transmission


def _power_balance(tr, res, qd):
    """Input power, output power and the loss accounted branch by branch and reducer by reducer."""
    qd_m = tr.motor_from_joint(qd)
    p_in = qd_m @ res.torque_motor
    p_out = qd @ res.torque_joint
    Sdot = tr.branch_velocities(qd)
    n = tr.n
    branch_loss = 0.0
    reducer_loss = 0.0
    m = tr.model
    for i in range(n):
        up = res.tension_motor[i]
        for b in range(i + 1):
            down = res.tension[i, b]
            branch_loss += (up - down) * Sdot[i, b]
            up = down
        pulley_power = m.driven_radius[i] * res.tension[i, i] * m.reducer_ratio[i] * qd[i]
        own = res.torque_joint[i] - sum(tr.K[k, i] * res.tension[k, i] for k in range(i + 1, n))
        reducer_loss += pulley_power - own * qd[i]
    return p_in, p_out, branch_loss, reducer_loss


def test_C4_power_in_exceeds_power_out_random(rng, count):
    """C4–C6: with losses, power in ≥ power out in every random case (both directions); the
    difference is exactly the branch and reducer losses, each ≥ 0."""
    for k in range(count):
        tr = random_routing(rng, losses=True)
        qd = rng.normal(size=tr.n)
        if k % 2:
            res = tr.feedforward(rng.normal(size=tr.n) * 2, qd)
        else:
            res = tr.forward(rng.normal(size=tr.n) * 0.2, qd)
        p_in, p_out, lb, lr = _power_balance(tr, res, qd)
        assert p_in - p_out > 0, (p_in, p_out)
        assert lb > 0 and lr >= -1e-12
        assert p_in - p_out == pytest.approx(lb + lr, rel=1e-9, abs=1e-12)


def test_C4_equality_only_without_losses(rng):
    """With every loss parameter zero the loss path equals the lossless statics (power conserved)."""
    for _ in range(300):
        tr = random_routing(rng, losses=False)
        qd = rng.normal(size=tr.n)
        tau = rng.normal(size=tr.n)
        a = tr.feedforward(tau, qd)
        b = tr.feedforward(tau, losses=False)
        np.testing.assert_allclose(a.torque_motor, b.torque_motor, rtol=1e-12, atol=1e-14)
        p_in, p_out, _, _ = _power_balance(tr, a, qd)
        assert abs(p_in - p_out) <= 1e-12 * max(1, abs(p_in))


def test_C4_feedforward_and_forward_are_inverse_while_moving(rng, count):
    for _ in range(count):
        tr = random_routing(rng, losses=True)
        qd = rng.normal(size=tr.n)
        tau = rng.normal(size=tr.n) * 3
        res = tr.feedforward(tau, qd)
        back = tr.forward(res.torque_motor, qd)
        np.testing.assert_allclose(back.torque_joint, tau, rtol=1e-9, atol=1e-10)


def _one_joint(**kw):
    # motor pulley 10 mm, driven pulley 50 mm, no reducer: ratio 5
    return Transmission.from_arrays([0.01], [[0.05]], **kw)


def test_C4_tau0_form_and_direction_of_power_flow(claims_ctx):
    """C4: Δτ = τ0 sgn(Ṡ) + ν Ṡ: the drop is from motor to joint when the motor drives,
    and reverses when the joint back-drives the cable."""
    assert_claim("C4", claims_ctx)


def test_C4_beta_form_is_a_capstan():
    """C4: with β = 1 − e^{−μθ} a branch is a capstan wrap τ_out = τ_in e^{−μθ}, in both directions
    (Euler–Eytelwein; reference values from numpy, not from the core's capstan helpers)."""
    mu, wrap = 0.15, 2 * np.pi
    beta = 1.0 - np.exp(-mu * wrap)
    assert _core.capstan_beta(mu, wrap) == pytest.approx(beta, rel=1e-15)
    assert _core.capstan_tension_out(30.0, mu, wrap) == pytest.approx(30.0 * np.exp(-mu * wrap), rel=1e-15)
    tr = _one_joint(beta=[[beta]])
    t_joint = 30.0
    drive = tr.feedforward([t_joint * 0.05], [1.0])      # motor drives: τ_joint = τ_motor e^{−μθ}
    assert drive.tension_motor[0] == pytest.approx(t_joint * np.exp(mu * wrap), rel=1e-12)
    back = tr.feedforward([t_joint * 0.05], [-1.0])      # joint drives: τ_motor = τ_joint e^{−μθ}
    assert back.tension_motor[0] == pytest.approx(t_joint * np.exp(-mu * wrap), rel=1e-12)
    fwd = tr.forward([0.01 * 40.0], [1.0])               # forward: 40 N in, 40 e^{−μθ} N out
    assert fwd.tension[0, 0] == pytest.approx(40.0 * np.exp(-mu * wrap), rel=1e-12)


def test_C4_stuck_below_breakaway():
    """C4: at rest a branch passes nothing until the drive exceeds static friction."""
    tr = _one_joint(tau0=[[2.0]])
    weak = tr.forward([0.01 * 1.5], [0.0])               # 1.5 N < 2 N break-away
    assert weak.stuck[0, 0] and weak.torque_joint[0] == 0.0
    strong = tr.forward([0.01 * 5.0], [0.0])             # 5 N: passes 3 N
    assert not strong.stuck[0, 0]
    assert strong.torque_joint[0] == pytest.approx(3.0 * 0.05)
    held = tr.feedforward([0.1], [0.0])                  # feedforward at rest: no compensation
    assert held.stuck[0, 0] and held.tension_motor[0] == pytest.approx(0.1 / 0.05)


def test_C5_bearing_law_every_branch(claims_ctx):
    """C5, S0 eqs. 7–8: static below α p; β p + h(n) moving, h = h0 below n0, h1 n^{2/3} above.
    (The scalar law; the branch law the statics and the simulator use is tested in test_branch_law.py
    and test_sim_physics.py.)"""
    assert_claim("C5", claims_ctx)


def test_C5_bearings_make_friction_grow_with_tension():
    """A branch with bearings loses more at higher tension (radial load 2 sin(θ/2)(T_pre + |τ|))."""
    kw = dict(bearing_count=[[2]], bearing_radius=[[0.01]], bearing_wrap=[[np.pi]],
              bearing_static_coefficient=[[2e-4]], bearing_dynamic_coefficient=[[1.5e-4]], bearing_h0=[[1e-4]],
              bearing_h1=[[2e-5]], bearing_n0=[[5.0]], pretension=[20.0])
    tr = _one_joint(**kw)
    losses = [tr.feedforward([t * 0.05], [1.0]).tension_motor[0] - t for t in (10.0, 50.0, 100.0)]
    assert losses[0] < losses[1] < losses[2]
    f = _core.branch_friction(tr.model, 0, 0, 0.05)
    assert f.b == pytest.approx(2 * 1.5e-4 * 2.0 / 0.01)        # count β_b 2 sin(π/2) / r


def test_C6_reducer_efficiencies(claims_ctx):
    """C6, S0 eq. 10: η_d = 0.9 → η_i = 0.8889; η_d ≤ 0.5 is self-locking."""
    assert_claim("C6", claims_ctx)


def test_C6_self_locking_reducer_holds_back_driving_load():
    tr = Transmission.from_arrays([0.008], [[0.32]], reducer_ratio=[8.0], reducer_efficiency=[0.4])
    res = tr.feedforward([1.0], [-1.0])
    assert res.status == _core.Status.SelfLocked and res.self_locked[0]
    assert res.torque_motor[0] == 0.0
    res = tr.feedforward([1.0], [1.0])                         # driving is fine
    assert res.status == _core.Status.Ok
    assert res.torque_motor[0] == pytest.approx(0.008 / 0.04 / (8 * 0.4))
