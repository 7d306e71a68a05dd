"""The branch friction law as the statics use it (losses.hpp ``branch_friction`` inside ``feedforward`` /
``forward``), against values computed by hand from S0 eqs. 7–8 and 11–12 (ERRATA: motion sign restored).
Claims C4 (stuck case, break-away, direction of power flow) and C5 (bearing law).

Every expected number below is written out from the equations, never taken from the code under test.

Bearing law (S0 eqs. 7–8) on a branch with ``count`` identical bearings of radius r, cable wrap θ:
  radial load           p = 2 sin(θ/2) (T_pre + |τ|)                                   [N]
  torque, at rest       M ≤ α p  (static threshold, break-away)                        [N·m]
  torque, moving        M = β p + h(n),  h = h0 for n < n0, h1 n^(2/3) above,  n = |Ṡ| / r [rad/s]
  as a cable force      f = count · M / r = a + b |τ|
                        a = count (c 2 sin(θ/2) T_pre + h) / r,  b = count c 2 sin(θ/2) / r,
                        c = α at rest (h = 0), c = β moving.
"""

import numpy as np
import pytest

from tendyn.transmission import Transmission

# one joint: motor pulley 10 mm, driven pulley 50 mm (no reducer); two bearings of 10 mm, cable wrap π
R_M, R_D = 0.01, 0.05
BEARINGS = dict(count=2.0, radius=0.01, wrap=np.pi, static_coefficient=2e-4, dynamic_coefficient=1.5e-4, h0=1e-4, h1=1e-4, n0=5.0)
T_PRE = 20.0


def one_joint_with_bearings(**over):
    b = dict(BEARINGS, **over)
    return Transmission.from_arrays(
        [R_M], [[R_D]], pretension=[T_PRE],
        **{f"bearing_{k}": [[v]] for k, v in b.items()})


def hand_ab(moving: bool, cable_speed: float = 0.0, b=BEARINGS):
    """(a, b) of the branch law, written out: k = 2 sin(π/2) = 2 exactly, r = 0.01 m."""
    load_per_tension = 2.0 * np.sin(b["wrap"] / 2)
    c = b["dynamic_coefficient"] if moving else b["static_coefficient"]
    if moving:
        n = abs(cable_speed) / b["radius"]                      # pulley speed [rad/s], not the cable's m/s
        h = b["h0"] if n < b["n0"] else b["h1"] * n ** (2.0 / 3.0)
    else:
        h = 0.0
    a = b["count"] * (c * load_per_tension * T_PRE + h) / b["radius"]
    bb = b["count"] * c * load_per_tension / b["radius"]
    return a, bb


def test_C5_hand_values_of_the_branch_law():
    """The hand formula itself, evaluated once to plain numbers (so the oracle is visible):
    at rest a = 2·(2e-4·2·20)/0.01 = 1.6 N, b = 2·2e-4·2/0.01 = 0.08; moving at Ṡ = 0.3 m/s the pulley
    turns at n = 30 rad/s > n0, h = 1e-4·30^(2/3) = 9.6549e-4 N·m, a = 2·(1.5e-4·2·20 + h)/0.01 = 1.39310 N,
    b = 0.06."""
    a, b = hand_ab(False)
    assert (a, b) == pytest.approx((1.6, 0.08), rel=1e-14)
    a, b = hand_ab(True, 0.3)
    assert a == pytest.approx(200 * (6e-3 + 1e-4 * 30 ** (2 / 3)), rel=1e-14)
    assert a == pytest.approx(1.39310, rel=1e-5) and b == pytest.approx(0.06, rel=1e-14)


@pytest.mark.parametrize("qd", [6.0, -6.0, 0.4])
def test_C5_feedforward_moving_uses_beta_pulley_speed_and_pretension(qd):
    """C5 moving: feedforward tension at the motor, driving case (power from motor to joint).

    Ṡ = R_D q̇. Driving with x = τ/R_D > 0 and Ṡ > 0: y − b y = x + a ⇒ y = (x + a)/(1 − b).
    Back-driven (Ṡ < 0, x > 0): y + b x = x − a ⇒ y = x (1 − b) − a (the joint side is the larger tension).
    q̇ = 6 rad/s: n = 30 rad/s (h1 branch); q̇ = 0.4: Ṡ = 0.02 m/s, n = 2 rad/s < n0 (h0 branch).
    Catches: cable speed [m/s] used as pulley speed (h0 instead of h1 n^(2/3) at 6 rad/s, and h1 branch
    would not be reached), the pretension's share of the load dropped, α used while moving."""
    tr = one_joint_with_bearings()
    x = 30.0                                            # N wanted at the driven pulley
    sdot = R_D * qd
    a, b = hand_ab(True, sdot)
    expected = (x + a) / (1 - b) if sdot > 0 else x * (1 - b) - a
    res = tr.feedforward([x * R_D], [qd])
    assert res.tension_motor[0] == pytest.approx(expected, rel=1e-12)
    assert res.torque_motor[0] == pytest.approx(R_M * expected, rel=1e-12)


def test_C5_speed_units_pinned_at_the_threshold():
    """n0 = 5 rad/s is crossed at Ṡ = n0 r = 0.05 m/s: just below, h = h0; just above, h1 n^(2/3).
    With the cable speed taken as n the threshold would sit at Ṡ = 5 m/s (q̇ = 100 rad/s)."""
    tr = one_joint_with_bearings(h0=5e-4, h1=1e-5)
    x = 10.0
    below = tr.feedforward([x * R_D], [0.049 / R_D]).tension_motor[0]
    above = tr.feedforward([x * R_D], [0.051 / R_D]).tension_motor[0]
    a_lo = 2 * (1.5e-4 * 2 * T_PRE + 5e-4) / 0.01
    a_hi = 2 * (1.5e-4 * 2 * T_PRE + 1e-5 * 5.1 ** (2 / 3)) / 0.01
    assert below == pytest.approx((x + a_lo) / 0.94, rel=1e-12)
    assert above == pytest.approx((x + a_hi) / 0.94, rel=1e-12)


def test_C5_forward_at_rest_breaks_away_at_alpha_p():
    """C5 at rest (Ṡ = 0), forward statics: the branch passes nothing while |t| ≤ a + b|t| with the
    STATIC coefficient α (a = 1.6 N, b = 0.08), and t − sgn(t)(a + b|t|) past break-away; h does not enter.

    t = 1.5 N: α threshold 1.6 + 0.12 = 1.72 N > 1.5 ⇒ stuck (with β it would be 1.2 + 0.09 = 1.29 < 1.5,
    passing 0.21 N). t = ±10 N: threshold 1.6 + 0.8 = 2.4 N ⇒ passes ±7.6 N, τ_J = ±7.6·0.05 = ±0.38 N·m."""
    tr = one_joint_with_bearings()
    weak = tr.forward([1.5 * R_M], [0.0])
    assert weak.stuck[0, 0] and weak.torque_joint[0] == 0.0
    for t in (10.0, -10.0):
        res = tr.forward([t * R_M], [0.0])
        assert not res.stuck[0, 0]
        assert res.tension[0, 0] == pytest.approx(np.sign(t) * 7.6, rel=1e-12)
        assert res.torque_joint[0] == pytest.approx(np.sign(t) * 0.38, rel=1e-12)


def test_C5_forward_moving_bearing_loss():
    """Forward (motor → joint), moving: x + s b max(|x|,|y|) = y − s a. Driving (Ṡ > 0, y > x > 0):
    x = y (1 − b) − a. With y = 40 N at q̇ = 6 rad/s: x = 40·0.94 − 1.39310 N."""
    tr = one_joint_with_bearings()
    a, b = hand_ab(True, R_D * 6.0)
    res = tr.forward([40.0 * R_M], [6.0])
    assert res.tension[0, 0] == pytest.approx(40.0 * (1 - b) - a, rel=1e-12)


# ---------------------------------------------------------------------------------------------------------
# Branches at rest in the forward statics: multi-joint chains, both signs, break-away (C4 stuck case)
# ---------------------------------------------------------------------------------------------------------

# two joints: K = [[R1, 0], [r21, R2]], motor radii 10 mm; cable 2 crosses joint 1 on a 20 mm idle pulley
R1, R21, R2 = 0.05, 0.02, 0.04
TAU0 = np.array([[1.0, 0.0], [0.5, 0.8]])      # [N] per branch
BETA = np.array([[0.1, 0.0], [0.05, 0.0]])     # [-] tension-proportional part (static threshold too)
NU = np.array([[0.0, 0.0], [0.0, 10.0]])       # [N·s/m]


def two_joints():
    return Transmission.from_arrays([0.01, 0.01], [[R1, 0.0], [R21, R2]], tau0=TAU0, beta=BETA, nu=NU)


def stuck_pass(t, a, b):
    """Forward through a branch at rest (hand form of S0's stuck case): nothing while |t| ≤ a + b|t|,
    t − sgn(t)(a + b|t|) beyond."""
    thr = a + b * abs(t)
    return 0.0 if abs(t) <= thr else t - np.sign(t) * thr


@pytest.mark.parametrize("t1, t2", [(5.0, -6.0), (-5.0, 6.0), (1.05, 0.5), (-20.0, -20.0)])
def test_C4_forward_all_branches_at_rest_two_joints(t1, t2):
    """All joints at rest, both signs of the drive: each cable loses its static friction branch by branch,
    in the direction of its drive; a branch whose drive is below break-away passes nothing downstream.

    Cable 1: one branch (a = 1, b = 0.1). Cable 2: branch 0 (a = 0.5, b = 0.05), then branch 1 (a = 0.8).
    Joint torques: τ1 = R1 x1 + r21 t2', τ2 = R2 t2'' (t2' after branch 0, t2'' after branch 1)."""
    tr = two_joints()
    res = tr.forward([t1 * 0.01, t2 * 0.01], [0.0, 0.0])
    x1 = stuck_pass(t1, 1.0, 0.1)
    y2 = stuck_pass(t2, 0.5, 0.05)
    x2 = stuck_pass(y2, 0.8, 0.0)
    np.testing.assert_allclose(res.tension[0, 0], x1, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(res.tension[1], [y2, x2], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(res.torque_joint, [R1 * x1 + R21 * y2, R2 * x2], rtol=1e-12, atol=1e-15)
    assert bool(res.stuck[0, 0]) == (x1 == 0.0) and bool(res.stuck[1, 0]) == (y2 == 0.0)


def test_C4_forward_hand_numbers_two_joints():
    """The same case as plain numbers: t = (5, −6) N. Cable 1: 5 − (1 + 0.5) = 3.5 N. Cable 2:
    −6 + (0.5 + 0.3) = −5.2 N, then −5.2 + 0.8 = −4.4 N. τ = (0.05·3.5 + 0.02·(−5.2), 0.04·(−4.4))
    = (0.071, −0.176) N·m. (1.05, 0.5) N: cable 1 threshold 1.105 N, cable 2 threshold 0.525 N:
    both stuck, no torque at all."""
    tr = two_joints()
    res = tr.forward([0.05, -0.06], [0.0, 0.0])
    np.testing.assert_allclose(res.torque_joint, [0.071, -0.176], rtol=1e-12)
    weak = tr.forward([0.0105, 0.005], [0.0, 0.0])
    assert weak.stuck[0, 0] and weak.stuck[1, 0]
    np.testing.assert_array_equal(weak.torque_joint, [0.0, 0.0])


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_C4_forward_stuck_proximal_branch_moving_distal(sign):
    """S1-like state: joint 1 turns, joint 2 turns so that cable 2's first branch is at rest,
    Ṡ_20 = r21 q̇1 + R2 q̇2 = 0, while its branch on link 2 slides (Ṡ_21 = R2 q̇2 ≠ 0).

    Cable 2, drive t2 = 6·sign N: branch 0 at rest passes 6 − (0.5 + 0.05·6) = 5.2 N in the drive's
    direction; branch 1 slides with Ṡ = R2 q̇2 (ν = 10 N·s/m, a = 0.8, b = 0): x = y − s a − ν Ṡ.
    Cable 1 (Ṡ_10 = R1 q̇1): x = y − s a − s b max(|x|,|y|) ⇒ for y > 0 driving, x = y(1 − b) − a."""
    tr = two_joints()
    qd1 = 1.0 * sign
    qd2 = -R21 * qd1 / R2
    t1, t2 = 10.0 * sign, 6.0 * sign
    res = tr.forward([t1 * 0.01, t2 * 0.01], [qd1, qd2])
    sdot = tr.branch_velocities([qd1, qd2])
    assert sdot[1, 0] == 0.0 and sdot[1, 1] != 0.0               # at rest, past break-away: not stuck
    assert not res.stuck[1, 0] and not res.stuck[1, 1] and not res.stuck[0, 0]
    y2 = sign * 5.2
    s21 = R2 * qd2
    x2 = y2 - np.sign(s21) * 0.8 - 10.0 * s21
    s10 = R1 * qd1
    # cable 1 drives its joint in both cases (t1 and Ṡ have the same sign): |x| < |y|
    x1 = t1 - np.sign(s10) * (1.0 + 0.1 * abs(t1))
    np.testing.assert_allclose(res.tension[1], [y2, x2], rtol=1e-12)
    np.testing.assert_allclose(res.tension[0, 0], x1, rtol=1e-12)
    np.testing.assert_allclose(res.torque_joint, [R1 * x1 + R21 * y2, R2 * x2], rtol=1e-12)


def test_C4_feedforward_stuck_branch_passes_tension_unchanged():
    """Feedforward at rest: static friction is not compensated (S0 §III): a branch at rest passes the
    tension unchanged, on a multi-joint chain too; moving branches add their loss (here cable 1 moves)."""
    tr = two_joints()
    qd1 = 1.0
    qd2 = -R21 * qd1 / R2                               # cable 2's first branch at rest
    tau = np.array([0.3, 0.2])
    res = tr.feedforward(tau, [qd1, qd2])
    # cable 2: x = τ2/R2 = 5 N at the joint; branch 1 slides with Ṡ = R2 q̇2 < 0 (back-driven by the
    # motion, x > 0): y − s b … = x + s a + ν Ṡ with b = 0: y = 5 − 0.8 + 10 Ṡ; branch 0 stuck: unchanged
    s21 = R2 * qd2
    y2 = 5.0 - 0.8 + 10.0 * s21
    assert res.stuck[1, 0] and not res.stuck[1, 1]
    assert res.tension_motor[1] == pytest.approx(y2, rel=1e-12)
    # cable 1: joint 1 needs τ1 − r21 t2(at joint 1) from its own cable; t2 at joint 1 is y2 (after branch 0)
    x1 = (0.3 - R21 * y2) / R1
    y1 = (x1 + 1.0) / (1 - 0.1) if x1 > 0 else None
    assert y1 is not None
    assert res.tension_motor[0] == pytest.approx(y1, rel=1e-12)
