"""The simulator on the CEA branch twin: closed-loop dynamics through Lᵀ (S2 eq. 12), elastic capstan
drives, energy, blocked-link stiffness and hysteresis, the t1/t2/t3 friction trajectories (C34)."""

import numpy as np
import pytest

from tendyn import _core
from tendyn.device import load_device
from tendyn.device.closed_loop import active_coordinate_map, active_dynamics
from tendyn.device.rigid_body import pinocchio_model
from tendyn.devices import bundled
from tendyn.sim import experiments as ex
from tendyn.sim.model import run_log, sim_model

Q0 = np.array([0.0, 0.3, 1.2])


@pytest.fixture(scope="module")
def cea():
    return load_device(bundled("cea_branch"))


def test_closed_loop_step_matches_inverse_dynamics(cea, rng):
    """One frictionless step: the active-joint acceleration satisfies Lᵀ rnea(q, q̇, q̈) = N·spring − offset,
    the inverse dynamics of the constrained branch (checked against a sympy Lagrangian elsewhere)."""
    m = sim_model(cea, friction=False, sensors=False)
    _, L, c = active_coordinate_map(cea)
    pm = pinocchio_model(cea)
    N = np.array(m.ratio)
    K = np.array(m.stiffness_motor)
    offset = np.array(m.offset_joint)
    for _ in range(15):
        qa = Q0 + rng.uniform(-0.3, 0.3, 3)
        va = rng.normal(size=3) * 0.5
        qm = N * qa + rng.normal(size=3) * 0.05      # wound springs
        d = _core.SimData(m)
        d.reset(qa, 0)
        d.set_motor_position(qm)
        d.set_velocity(va, N * va)
        z = np.zeros(3)
        _core.step(m, d, z, z, z, z)
        acc = (np.array(d.qd) - va) / m.dt
        spring = K * (qm - N * qa)
        np.testing.assert_allclose(active_dynamics(pm, L, c, qa, va, acc), N * spring - offset, rtol=1e-8, atol=1e-9)


def test_energy_conserved_with_capstan_springs(cea):
    m = sim_model(cea, friction=False, sensors=False, rate_hz=10_000)
    d = _core.SimData(m)
    d.reset(Q0, 0)
    d.set_motor_position(np.array(m.ratio) * Q0 + 0.2)   # wound springs: the motors ring at ~100 Hz
    e0 = _core.mechanical_energy(m, d)
    z = np.zeros((100_000, 3))
    log = run_log(m, d, z, z, z, z, 10)
    assert np.ptp(log["q_joint"][:, 1]) > 0.3
    e1 = _core.mechanical_energy(m, d)
    # the torque offsets of Table 4 are constant torques: their work is the only energy exchange
    assert abs(d.work_external) > 0.05
    assert abs(e1 - e0 - d.work_external) < 0.02 * abs(d.work_external), (e0, e1, d.work_external)


def test_blocked_link_capstan_stiffness_and_hysteresis(cea):
    """Blocked links, triangular motor torque: the motor turns on the capstan spring, slope K_T = 2 N·m/rad
    motor side (S2 Table 2, ERRATA eq. 19); motor Coulomb friction opens a hysteresis loop (C31)."""
    run = ex.blocked_link(cea, joint=2, torque_amplitude=0.1, period=2.0, cycles=2, seed=0)
    qm = run.states["q_motor"][:, 1] - 20 * Q0[1] * 0 - run.states["q_motor"][0, 1]
    tau = run.log["torque_motor_cmd_2"]
    assert np.all(np.abs(run.states["qd_joint"]) < 1e-9)            # links blocked
    slope = np.polyfit(qm, tau, 1)[0]
    assert slope == pytest.approx(2.0, rel=0.03)
    # hysteresis: at the same torque the motor angle differs going up and down by ≈ 2 F_c / K_T
    fc = cea.drives[1].coulomb_motor
    up = np.gradient(tau) > 0
    grid = np.linspace(-0.05, 0.05, 11)
    gap = np.interp(grid, tau[~up][np.argsort(tau[~up])], qm[~up][np.argsort(tau[~up])]) - \
        np.interp(grid, tau[up][np.argsort(tau[up])], qm[up][np.argsort(tau[up])])
    assert np.median(gap) == pytest.approx(2 * fc / 2.0, rel=0.2)


@pytest.mark.parametrize("kind, moving, still", [("t1", [1, 2], []), ("t2", [1], [2]), ("t3", [2], [1])])
def test_cea_friction_trajectories(cea, kind, moving, still):
    """S2 §V-C: t1 moves q2 and q5 together (q̇5 = q̇2), t2 holds q5, t3 holds q2 (C34)."""
    run = ex.cea_friction_trajectory(cea, kind, speeds=(0.3,), travel=0.3, q0=Q0, seed=1)
    qd = run.states["qd_joint"]
    cruise = np.abs(np.abs(run.log.stack("qd_ref_")[:, moving[0]]) - 0.3) < 1e-9
    assert cruise.sum() > 300
    for j in moving:
        assert np.median(np.abs(qd[cruise, j])) == pytest.approx(0.3, rel=0.05)
    for j in still + [0]:
        assert np.median(np.abs(qd[cruise, j])) < 0.01
    assert run.log.meta["experiment"] == f"friction_{kind}"
