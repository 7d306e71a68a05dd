"""Transmission kinematics and lossless statics (S0 eqs. 1–5 corrected: ERRATA). Claims C1–C3."""

import numpy as np
import pytest

from routing_cases import random_routing
from tendyn.claims import assert_claim
from tendyn.transmission import Transmission


def test_C1_round_trip_random_routings(claims_ctx):
    """C1: motor → joint → motor and joint → motor → joint to 1e-12 on ≥ 1000 seeded routings of 1–7 joints."""
    assert_claim("C1", claims_ctx)


def test_C1_branch_recursion_matches_driven_joint(rng):
    """C1: the branch recursion S_j = S_{j−1} − r_j q_j ends with S_{i−1} = r_i^i q_i at the driven joint."""
    for _ in range(200):
        tr = random_routing(rng)
        q = rng.uniform(-2, 2, tr.n)
        S = tr.branch_displacements(q)
        # the last branch of transmission i wraps its driven pulley: S[i, i] = K_ii q_i
        np.testing.assert_allclose(np.diag(S), np.diag(tr.K) * q, atol=1e-12)
        # and S0 eq. 1 at the motor
        np.testing.assert_allclose(S[:, 0], np.diag(tr.model.motor_radius) @ tr.motor_from_joint(q), atol=1e-12)


def test_C1_matrices_are_mutual_inverses(rng):
    for _ in range(200):
        tr = random_routing(rng)
        M = tr.matrices()
        I = np.eye(tr.n)
        np.testing.assert_allclose(M["joint_from_motor_position"] @ M["motor_from_joint_position"], I, atol=1e-10)
        np.testing.assert_allclose(M["joint_from_motor_torque"] @ M["motor_from_joint_torque"], I, atol=1e-10)
        # torque maps are the transposes of the position maps (virtual work)
        np.testing.assert_allclose(M["joint_from_motor_torque"], M["motor_from_joint_position"].T, atol=1e-12)


def test_C3_lossless_virtual_work(claims_ctx):
    """C3: τ_J = Kᵀt, C_m = R_m t; q̇ᵀτ_J = q̇_mᵀC_m to 1e-12, in both directions."""
    assert_claim("C3", claims_ctx)


def test_two_joint_routing_closed_form():
    """A two-joint routing against the closed form derived by hand.

    K = [[R1, 0], [r21, R2]]: q1 = r_m1 q_m1 / R1, q2 = (r_m2 q_m2 − r21 q1) / R2;
    τ1 = R1 t1 + r21 t2, τ2 = R2 t2 with t = C_m / r_m. This is the structure of ros2_control's
    four-bar-linkage transmission (joint 2 moves with actuator 1 through joint 1).
    """
    r_m1, r_m2, R1, r21, R2 = 0.01, 0.012, 0.32, -0.015, 0.24
    tr = Transmission.from_arrays([r_m1, r_m2], [[R1, 0], [r21, R2]])
    J_from_M = np.array([[r_m1 / R1, 0], [-r21 * r_m1 / (R1 * R2), r_m2 / R2]])
    np.testing.assert_allclose(tr.matrices()["joint_from_motor_position"], J_from_M, rtol=1e-14)
    tau_from_C = np.array([[R1 / r_m1, r21 / r_m2], [0, R2 / r_m2]])
    np.testing.assert_allclose(tr.matrices()["joint_from_motor_torque"], tau_from_C, rtol=1e-14)
    C_from_tau = np.array([[r_m1 / R1, -r_m1 * r21 / (R1 * R2)], [0, r_m2 / R2]])
    np.testing.assert_allclose(tr.matrices()["motor_from_joint_torque"], C_from_tau, rtol=1e-14)

    # ros2_control FourBarLinkageTransmission with joint reduction jr1 = 1 (its position and effort
    # maps agree with virtual work only then): ar1 = R1/r_m1, ar2 = r21/r_m2, jr2 = R2/r21.
    ar1, ar2, jr2 = R1 / r_m1, r21 / r_m2, R2 / r21
    a = np.array([0.7, -1.3])
    j1 = a[0] / ar1
    j2 = (a[1] / ar2 - a[0] / ar1) / jr2
    np.testing.assert_allclose(tr.joint_from_motor(a), [j1, j2], rtol=1e-13)
    e = np.array([0.2, 0.05])
    np.testing.assert_allclose(tr.forward(e, losses=False).torque_joint,
                               [ar1 * e[0] + ar2 * e[1], ar2 * jr2 * e[1]], rtol=1e-13)


def test_icub_shoulder_coupling_matrix():
    """An external coupling matrix reproduced from a routing: the iCub shoulder.

    robotology robots-configuration (left arm mechanicals) gives the motor → joint matrix
    [[1, 0, 0], [1, α, 0], [0, −α, α]], α = 40/65. With q = K⁻¹R_m q_m, K = R_m M⁻¹: the routing
    is 40 mm motor pulleys driving 65 mm joint pulleys, cables 2 and 3 crossing joint 1 on
    −65 mm idle pulleys and cable 3 crossing joint 2 on a +65 mm one, joint 1 driven 1:1.
    """
    alpha = 40 / 65
    M = np.array([[1, 0, 0], [1, alpha, 0], [0, -alpha, alpha]])
    r_m = np.array([0.065, 0.040, 0.040])
    K = np.array([[0.065, 0, 0], [-0.065, 0.065, 0], [-0.065, 0.065, 0.065]])
    tr = Transmission.from_arrays(r_m, K)
    np.testing.assert_allclose(tr.matrices()["joint_from_motor_position"], M, rtol=0, atol=1e-12)


def test_routing_table_and_generalised_radius_C2():
    """C2: r_i^i = r_pulley · n_i appears as the diagonal of K and in the routing table."""
    tr = Transmission.from_arrays([0.008], [[0.32]], reducer_ratio=[8.0])
    assert tr.model.driven_radius[0] == pytest.approx(0.04)
    row = tr.routing_table()[0]
    assert row["generalised_radius_m"] == pytest.approx(0.32)
    assert row["joint_per_motor_ratio"] == pytest.approx(40.0)


def test_bad_numeric_input_raises():
    tr = Transmission.from_arrays([0.01, 0.01], [[0.1, 0], [0.02, 0.1]])
    with pytest.raises(ValueError, match="NaN or Inf"):
        tr.joint_from_motor([np.nan, 0.0])
    with pytest.raises(ValueError, match=r"q must be a 1-D array of 2 finite floats \(got shape \(3,\)\)"):
        tr.motor_from_joint([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="NaN or Inf"):
        tr.feedforward([np.inf, 0.0], [0.1, 0.1])


def test_singular_routing_rejected():
    with pytest.raises(ValueError, match="singular"):
        Transmission.from_arrays([0.01, 0.01], [[0.1, 0], [0.02, 0.0]])
