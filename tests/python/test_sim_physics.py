"""Simulator physics against analytic oracles that do not use the simulator's impulses (include/tendyn/sim.hpp).

One revolute joint about the vertical axis (gravity gives no torque), one cable: every expected value is
derived by hand in the docstring from S0 (eqs. 7–10, ERRATA) and Newton's law on the link, the rotor and
the cable. Claims C4, C5, C6 (friction sites in the loop) and the sensor / controller models of
docs/simulator.md (encoder quantisation, velocity estimator, current noise, PID).
"""

from __future__ import annotations

import numpy as np
import pytest

from tendyn import _core
from tendyn.device import load_device
from tendyn.sim.model import run_log, sim_model

# link: 1 kg at 0.1 m from the axis, 0.001 kg·m² about its COM ⇒ J_link = 0.001 + 1·0.1² = 0.011 kg·m²
J_LINK = 0.011


def one_joint(tmp_path, *, motor_radius=0.01, driven_radius=0.05, reducer_ratio=1.0, reducer_efficiency=1.0,
              pretension=0.0, tau0=0.0, nu=0.0, beta=0.0, bearings=None, rotor_inertia=1e-5,
              torque_constant=0.1, encoder_counts=4096, current_noise=0.0, peak_torque=2.0):
    """Load a one-joint, one-cable device file (the only place this module spells the file format)."""
    bear = ""
    if bearings:
        bear = "bearings = [{" + ", ".join(f"{k} = {v!r}" for k, v in bearings.items()) + "}]\n"
    text = f"""
schema = 1
[device]
name = "one cable"
[kinematics]
convention = "dh"
gravity = [0.0, 0.0, -9.81]
[[kinematics.joints]]
name = "j1"
a = 0.2
alpha = 0.0
d = 0.0
lower = -100.0
upper = 100.0
mass = 1.0
com = [-0.1, 0.0, 0.0]
inertia = [0.001, 0.001, 0.001, 0.0, 0.0, 0.0]
[[transmissions]]
name = "t1"
joint = 1
motor_radius = {motor_radius!r}
driven_radius = {driven_radius!r}
reducer_ratio = {reducer_ratio!r}
reducer_efficiency = {reducer_efficiency!r}
pretension = {pretension!r}
friction = [{{tau0 = {tau0!r}, nu = {nu!r}, beta = {beta!r}}}]
{bear}[transmissions.motor]
torque_constant = {torque_constant!r}
rotor_inertia = {rotor_inertia!r}
continuous_torque = {min(0.5, peak_torque)!r}
peak_torque = {peak_torque!r}
[transmissions.sensors]
encoder_counts = {encoder_counts}
current_noise = {current_noise!r}
"""
    path = tmp_path / "one.toml"
    path.write_text(text)
    return load_device(path)


def run(m, d, steps, ff=0.0, ext=0.0, ref_q=0.0, ref_v=0.0, log_every=None):
    """Constant (or per-step) inputs for the one-joint model; returns the log dict."""
    def col(x):
        x = np.asarray(x, float)
        return np.broadcast_to(x.reshape(-1, 1) if x.ndim else x, (steps, 1)).copy()
    return run_log(m, d, col(ref_q), col(ref_v), col(ff), col(ext), log_every or m.control_decimation)


def start(m, q0, v0, ratio):
    d = _core.SimData(m)
    d.reset(np.array([q0]), 0)
    if v0:
        d.set_velocity(np.array([v0]), np.array([ratio * v0]))
    return d


# ---------------------------------------------------------------------------------------------------------
# Bearings in the loop (C5): static threshold α p at rest, β p + h(n) moving, n the PULLEY speed
# ---------------------------------------------------------------------------------------------------------

BEARINGS = dict(count=2, radius=0.01, wrap=np.pi, static_coefficient=2e-4, dynamic_coefficient=1.5e-4, h0=1e-4, h1=1e-4, n0=5.0)
T_PRE = 20.0


def test_C5_sim_bearing_breakaway_is_alpha_p_with_pretension(tmp_path):
    """At rest, no motor torque, an external torque τ on the joint. The branch (Ṡ = R q̇, R = 0.05 m)
    holds with friction force λ = τ/R; the cable carries λ on the joint side and 0 at the motor, so the
    bound is a + b|λ| with the static coefficients (bearing law, S0 eq. 7; p = 2 sin(θ/2)(T_pre + |τ|)):
      a = 2·(α·2·T_pre)/r = 2·(2e-4·2·20)/0.01 = 1.6 N,  b = 2·α·2/r = 0.08.
    It holds while λ(1 − b) ≤ a: τ* = R a/(1 − b) = 0.05·1.6/0.92 = 0.0869565 N·m.
    (With β at rest τ* would be 0.05·1.2/0.94 = 0.0638; without the pretension's share, 0.)"""
    dev = one_joint(tmp_path, pretension=T_PRE, bearings=BEARINGS)
    m = sim_model(dev, sensors=False, rate_hz=10_000)
    tau_star = 0.05 * 1.6 / 0.92
    steps = 15_000
    ramp = np.minimum(np.arange(steps) / 10_000, 1.0)
    d = start(m, 0.3, 0.0, 5.0)
    log = run(m, d, steps, ext=0.97 * tau_star * ramp)
    assert np.all(log["q_joint"][:, 0] == 0.3)                  # no creep at all below α p
    d = start(m, 0.3, 0.0, 5.0)
    log = run(m, d, steps, ext=1.03 * tau_star * ramp)
    assert log["q_joint"][-1, 0] > 0.3 + 1e-3                    # breaks away just above


def test_C5_sim_bearing_steady_speed_uses_pulley_speed(tmp_path):
    """Moving, no load, constant motor torque C_m. At a steady speed the rotor does not accelerate, the
    motor-side tension is t_m = C_m/r_m, the joint-side one is 0 (no load), so the branch slides with
    λ = t_m = a(n) + b t_m ⇒ t_m = a(n)/(1 − b), with the dynamic coefficients (S0 eqs. 7–8):
      q̇ = 6 rad/s: Ṡ = 0.3 m/s, pulley n = Ṡ/r = 30 rad/s > n0: h = 1e-4·30^(2/3) N·m,
      a = 2·(1.5e-4·2·20 + h)/0.01 = 1.39310 N, b = 0.06 ⇒ C_m = 0.01·a/0.94 = 0.0148202 N·m.
    Started at 6 rad/s with that torque, the joint keeps 6 rad/s (a slower or faster steady speed would
    mean another friction: e.g. h evaluated at 0.3 "rad/s" gives h0 and 0.38 rad/s of drift in 0.5 s)."""
    dev = one_joint(tmp_path, pretension=T_PRE, bearings=BEARINGS)
    m = sim_model(dev, sensors=False, rate_hz=10_000)
    a = 2 * (1.5e-4 * 2 * T_PRE + 1e-4 * 30 ** (2 / 3)) / 0.01
    cm = 0.01 * a / 0.94
    d = start(m, 0.0, 6.0, 5.0)
    log = run(m, d, 5000, ff=cm)
    v = log["qd_joint"][:, 0]
    assert v[-1] == pytest.approx(6.0, abs=2e-3), v[-1]
    assert np.ptp(v[100:]) < 2e-3


# ---------------------------------------------------------------------------------------------------------
# Reducers back-driven in the simulator (C6): the statics with losses at constant speed is the oracle
# ---------------------------------------------------------------------------------------------------------

def reducer_device(tmp_path, eta=0.9):
    # r_m = 8 mm, driven pulley 40 mm with n = 8 (generalised radius 0.32 m): as L-EXOS joints 1, 2
    return one_joint(tmp_path, motor_radius=0.008, driven_radius=0.04, reducer_ratio=8.0,
                     reducer_efficiency=eta)


@pytest.mark.parametrize("direction", ["back-driven", "driving"])
def test_C6_sim_reducer_constant_speed_matches_statics(tmp_path, direction):
    """Constant motor torque C_m = 0.05 N·m, cable lossless: the pulley torque seen through the reducer is
    n M_p = K C_m / r_m = 0.32·0.05/0.008 = 2.0 N·m. At constant speed the joint balances the external
    torque with what the reducer delivers (S0 eqs. 9–10, η_i = (2η_d − 1)/η_d = 0.8/0.9):
      driving (q̇ = +1):     τ_J = η_d n M_p = 1.8 N·m
      back-driven (q̇ = −1): τ_J = n M_p / η_i = 2.0·0.9/0.8 = 2.25 N·m (the joint pushes the motor).
    So with τ_ext = −τ_J the joint keeps its speed; the feedforward statics with losses, asked for τ_J at
    that speed, returns the same C_m. (A symmetric reducer box would give 2.2 N·m back-driven: 1.9 rad/s²
    of drift on J ≈ 0.027 kg·m².)"""
    dev = reducer_device(tmp_path)
    m = sim_model(dev, sensors=False, rate_hz=10_000)
    cm = 0.05
    qd, tau_j = (-1.0, 2.0 * 0.9 / 0.8) if direction == "back-driven" else (1.0, 0.9 * 2.0)
    # the statics with losses agree with the hand value (independent of the simulator)
    from tendyn.transmission import Transmission
    assert Transmission.from_device(dev).feedforward([tau_j], [qd]).torque_motor[0] == pytest.approx(cm, rel=1e-12)
    d = start(m, 0.0, qd, 40.0)
    log = run(m, d, 3000, ff=cm, ext=-tau_j)
    v = log["qd_joint"][:, 0]
    assert v[-1] == pytest.approx(qd, abs=3e-3), v[-1]
    assert np.ptp(v[10:]) < 3e-3


def test_C6_sim_self_locking_reducer_holds(tmp_path):
    """η_d = 0.4 ≤ 0.5: the joint cannot back-drive the reducer, whatever it pushes (S0 eq. 10, ERRATA):
    an external torque against a motor that pulls 2.0 N·m at the joint stays put; the motor still drives."""
    dev = reducer_device(tmp_path, eta=0.4)
    m = sim_model(dev, sensors=False, rate_hz=10_000)
    d = start(m, 0.1, 0.0, 40.0)
    log = run(m, d, 3000, ff=0.05, ext=-10.0)
    # (the first step moves by ~3e-6 rad: the friction boxes use the tensions of the previous step, zero
    # after reset; from the second step on the reducer holds, bit for bit)
    q = log["q_joint"][:, 0]
    assert abs(q[-1] - 0.1) < 1e-5 and np.all(q[1:] == q[-1])
    d = start(m, 0.1, 0.0, 40.0)
    log = run(m, d, 3000, ff=0.05, ext=-0.5)                    # η_d n M_p = 0.8 > 0.5: it drives
    assert log["q_joint"][-1, 0] > 0.1 + 1e-3


def test_C4_sim_rotor_inertia_takes_its_share_of_the_tension(tmp_path):
    """Accelerating from rest with a constant motor torque on a branch with β = 0.3 (no τ0, no ν).
    Newton on each body (rotor J_r, ratio G = R/r_m = 5; link J_l; driving: t_j = (1 − β) t_m):
      rotor  C_m − J_r G a = r_m t_m;   link  J_l a = R (1 − β) t_m
      ⇒ a = C_m / (J_r G + J_l r_m / (R (1 − β))).
    With J_r = 5e-4 kg·m² the rotor takes about half the torque; if the cable tension ignored it the friction
    (β t_m) would be larger and the acceleration 10 % lower."""
    jr, beta, R, rm = 5e-4, 0.3, 0.05, 0.01
    dev = one_joint(tmp_path, beta=beta, rotor_inertia=jr)
    m = sim_model(dev, sensors=False, rate_hz=10_000)
    cm = 0.05
    a = cm / (jr * (R / rm) + J_LINK * rm / (R * (1 - beta)))
    d = start(m, 0.0, 0.0, 5.0)
    log = run(m, d, 1000, ff=cm, log_every=10)
    t, v = log["time"], log["qd_joint"][:, 0]
    slope = np.polyfit(t[5:], v[5:], 1)[0]
    assert slope == pytest.approx(a, rel=2e-3), (slope, a)


# ---------------------------------------------------------------------------------------------------------
# Sensing and control
# ---------------------------------------------------------------------------------------------------------

def test_velocity_estimator_bandwidth_in_hz(tmp_path):
    """The velocity estimate is a first-order filter of the encoder differences with cut-off f_c [Hz]:
    v̂_k = v̂_{k−1} + α (Δq/T_c − v̂_{k−1}), α = 1 − exp(−2π f_c T_c). At a constant true speed v0 the first
    control sample has no difference yet (v̂_0 = 0), then v̂_k = v0 (1 − (1 − α)^k).
    f_c = 20 Hz, T_c = 1 ms: α = 1 − e^{−0.04π} = 0.11809 (Hz taken as rad/s would give 0.0198).
    v̂ is read through a pure-D joint controller (kd = 1, tiny torque limit so that it does not brake):
    the commanded motor torque is −(r_m/R) kd v̂."""
    dev = one_joint(tmp_path)          # a real motor in the file (the loader refuses a 1e-12 N·m one: g·cm²?)
    m = sim_model(dev, sensors=False, rate_hz=10_000, control_hz=1_000)
    m.peak_torque = np.array([1e-12])   # the tiny limit on the twin only
    m.mode = _core.ControlMode.JointPID
    m.kd = np.array([1.0])
    m.velocity_cutoff_hz = 20.0
    m.finalize()
    v0 = 0.8
    d = start(m, 0.0, v0, 5.0)
    log = run(m, d, 400)
    v_hat = -log["torque_motor_cmd"][:, 0] * 0.05 / 0.01
    k = np.arange(v_hat.size)
    alpha = 1.0 - np.exp(-2 * np.pi * 20.0 * 1e-3)
    assert alpha == pytest.approx(0.11809, abs=1e-5)
    np.testing.assert_allclose(v_hat, v0 * (1 - (1 - alpha) ** k), rtol=1e-6, atol=1e-9)


def test_encoder_quantisation_error_is_centred(tmp_path):
    """A 4096-count encoder rounds to the nearest count: the error q_meas − q_true lies in ±step/2 and
    averages to 0 over a slow sweep (truncation would bias it by −step/2). step = 2π/4096 rad."""
    dev = one_joint(tmp_path, encoder_counts=4096)
    m = sim_model(dev, sensors=True, rate_hz=10_000)
    d = start(m, 0.0, 0.37, 5.0)
    log = run(m, d, 20_000)
    step = 2 * np.pi / 4096
    err = log["q_motor_meas"][:, 0] - log["q_motor"][:, 0]
    assert np.abs(err).max() <= step / 2 + 1e-12
    assert abs(err.mean()) < 0.05 * step
    assert err.min() < -0.4 * step and err.max() > 0.4 * step


def test_current_noise_is_amps_times_torque_constant(tmp_path):
    """The measured motor torque is C_m + k_t · i_noise with i_noise ~ N(0, σ_i²) [A]: σ = 0.1·0.05 =
    5e-3 N·m for k_t = 0.1 N·m/A, σ_i = 0.05 A (not 0.05 N·m)."""
    dev = one_joint(tmp_path, torque_constant=0.1, current_noise=0.05)
    m = sim_model(dev, sensors=True, rate_hz=10_000)
    d = start(m, 0.0, 0.0, 5.0)
    log = run(m, d, 40_000, ff=0.01)
    noise = log["torque_motor_meas"][:, 0] - log["torque_motor_cmd"][:, 0]
    assert noise.std() == pytest.approx(5e-3, rel=0.06)
    assert abs(noise.mean()) < 5e-3 * 4 / np.sqrt(noise.size)


def test_pid_integral_is_over_time(tmp_path):
    """Joint PID, integral action only, joint blocked (lock_joint): the error e = 0.1 rad is constant, the
    integral after control sample k is (k + 1) e T_c, so the joint torque asked is ki (k + 1) e T_c and the
    motor torque (r_m/R) times that (lossless map)."""
    dev = one_joint(tmp_path)
    m = sim_model(dev, sensors=False, rate_hz=10_000, control_hz=1_000)
    m.mode = _core.ControlMode.JointPID
    m.ki = np.array([3.0])
    m.lock_joint = np.array([1.0])
    m.finalize()
    d = start(m, 0.2, 0.0, 5.0)
    log = run(m, d, 2000, ref_q=0.3)
    k = np.arange(log["time"].size)
    np.testing.assert_allclose(log["torque_motor_cmd"][:, 0], 0.2 * 3.0 * (k + 1) * 0.1 * 1e-3, rtol=1e-9)
