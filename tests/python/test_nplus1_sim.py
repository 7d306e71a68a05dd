"""The twin of N+1 devices (issue 19, item 2): n + 1 rigid tendons on n joints in the C++ simulator (sim.hpp,
DriveKind::Tendons), with the branch losses of S0 eq. 12 (τ0 sgn(Ṡ) + ν Ṡ, motion sign restored: ERRATA).

Oracles do not share the code under test: the reduced dynamics (M + Kᵀ R_m⁻¹ I_m R_m⁻¹ K) q̈ + b = Kᵀ R_m⁻¹ C_m are
written here and integrated by classical Runge–Kutta (torques held over each sample) with Pinocchio's Python crba /
rnea (the simulator steps its own one-pass tree dynamics, tree_dynamics.hpp, and a Moreau–Jean friction solve); the
energies come from Pinocchio and the branch speeds Ṡ_ib = Σ_{l ≥ b} K_il q̇_l and the dissipation τ0 |Ṡ| + ν Ṡ² are
summed here from the logged joint velocities and the hand-derived K of the finger
(python/tendyn/devices/tendon_finger.toml)."""

import numpy as np
import pinocchio as pin
import pytest

from tendyn import _core
from tendyn.cli import main
from tendyn.device import DeviceError, compile_device, load_device
from tendyn.devices import bundled
from tendyn.devices.generate import cable_device_toml
from tendyn.sim.model import run_log, sim_model
from tendyn.tendons import Tendons
from tendyn.transmission import Transmission

K_FINGER = np.array([[0.012, 0.0, 0.0],
                     [0.010, 0.010, 0.0],
                     [0.008, 0.008, 0.008],
                     [-0.010, -0.009, -0.007]])   # m, by hand from the file's header
R_M = 0.008                                       # m, every motor pulley of the finger
ROTOR = 1e-6                                      # kg·m², every rotor of the finger
RATE = 10_000.0                                   # Hz, integration = control = log rate
Q0_FINGER = np.array([0.3, 0.5, 0.4])


def _finger():
    return load_device(bundled("tendon_finger"))


def _generated(tmp_path, n, gravity=True):
    p = tmp_path / f"gen{n}.toml"
    p.write_text(cable_device_toml(n, n_plus_one=True, seed=n, planar=n % 2 == 0, gravity=gravity), encoding="utf-8")
    return load_device(p)


def _device_arrays(dev):
    """K (m, n) [m], motor radii (m,) [m], rotor inertias (m,) [kg·m²], τ0 and ν (m, n) of every branch, read from
    the device description (no core model)."""
    tr = dev.transmissions
    m, n = len(tr), dev.n_joints
    K = np.zeros((m, n))
    tau0, nu = np.zeros((m, n)), np.zeros((m, n))
    for i, t in enumerate(tr):
        K[i, t.joint - 1] = t.driven_radius
        for j, r in zip(t.crosses, t.crossed_radii):
            K[i, j - 1] = r
        for b, f in enumerate(t.friction):
            tau0[i, b], nu[i, b] = f.tau0, f.nu
    r_m = np.array([t.motor_radius for t in tr])
    rotor = np.array([t.motor.rotor_inertia for t in tr])
    return K, r_m, rotor, tau0, nu


def _run_torque(dev, ff, q0, friction=True, qd0=None, rate=RATE):
    """Torque mode, ideal sensors, control and log every step: the logs and the data."""
    m = sim_model(dev, rate_hz=rate, control_hz=rate, friction=friction, sensors=False)
    assert m.drive == _core.DriveKind.Tendons and m.nm == m.na + 1 and m.n_ff == m.nm
    d = _core.SimData(m)
    d.reset(np.asarray(q0, float), 0)
    if qd0 is not None:
        qd0 = np.asarray(qd0, float)
        d.set_velocity(qd0, np.array(m.Gm) @ qd0)
    n = ff.shape[0]
    z = np.zeros((n, m.na))
    return run_log(m, d, z, z, ff, z, 1), m, d


def _motor_torques(nm, n, scale, offset, rate=RATE):
    t = np.arange(n) / rate
    freqs = 1.0 + 0.37 * np.arange(nm)
    return offset + scale * np.sin(2 * np.pi * np.outer(t, freqs) + np.arange(nm))


def _reduced_rhs(pm, pd, K, r_m, rotor, torque_of_t, with_rotor=True):
    """ẋ of the reduced dynamics, x = (q, q̇): (M + Gᵀ I_m G) q̈ = Gᵀ C_m(t) − b(q, q̇), G = R_m⁻¹ K (derived in
    sim.hpp's header, written again here)."""
    G = K / r_m[:, None]
    Mr = G.T @ np.diag(rotor) @ G if with_rotor else 0.0
    n = K.shape[1]

    def f(t, x):
        q, v = x[:n], x[n:]
        M = pin.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        b = pin.rnea(pm, pd, q, v, np.zeros(n))
        a = np.linalg.solve(M + Mr, G.T @ torque_of_t(t) - b)
        return np.concatenate([v, a])
    return f


def _ode_oracle(dev, ff, q0, with_rotor=True, rate=RATE, substeps=1):
    """The reduced dynamics integrated by classical Runge–Kutta (4th order, written here), ``substeps`` steps per
    sample, the motor torques held over each sample as the simulator holds its commands: (n, nq) positions at the
    sample times. The torque is constant inside each RK4 step, so no step straddles a jump (scipy's DOP853 over the
    same held torques, rtol 1e-10, stepped through the jumps: 7e-8 rad away and 30–100× slower; two substeps move
    the result by < 1e-12 rad, test_the_ode_oracle_has_converged)."""
    compiled = compile_device(dev)
    L, c = compiled.active_map
    assert np.allclose(L, np.eye(L.shape[1])) and not np.any(c)   # serial chains: q_tree = q
    pm = compiled.pinocchio_model
    pd = pm.createData()
    K, r_m, rotor, _, _ = _device_arrays(dev)
    held = {"torque": ff[0]}
    rhs = _reduced_rhs(pm, pd, K, r_m, rotor, lambda t: held["torque"], with_rotor)
    # the simulator's semi-implicit step (v⁺ = v + h a, q⁺ = q + h v⁺) starts its positions a half step of
    # acceleration ahead; starting the oracle at v(0) = (h/2) a(0) removes that start-up term of the O(h) error
    nq = len(q0)
    x = np.concatenate([q0, 0.5 / rate * rhs(0.0, np.concatenate([q0, np.zeros(nq)]))[nq:]])
    h = 1.0 / rate / substeps
    out = np.empty((ff.shape[0], nq))
    for k, torque in enumerate(ff):
        out[k] = x[:nq]
        held["torque"] = torque
        for _ in range(substeps):
            k1 = rhs(0.0, x)
            k2 = rhs(0.0, x + 0.5 * h * k1)
            k3 = rhs(0.0, x + 0.5 * h * k2)
            k4 = rhs(0.0, x + h * k3)
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return out


def test_the_ode_oracle_has_converged():
    """The oracle's own error is far below what it checks: halving its step moves the finger's 50 ms by < 1e-10 rad
    (measured 1e-13), against the simulator's 2.4e-4 rad; and it is not a constant (the finger moves > 0.3 rad)."""
    dev = _finger()
    h = np.array([1 / 12, 1 / 5, 7 / 8, 1.0])
    ff = R_M * 10.0 * h + _motor_torques(4, 500, 0.002, 0.0)
    one, two = (_ode_oracle(dev, ff, Q0_FINGER, substeps=s) for s in (1, 2))
    assert np.abs(one - Q0_FINGER).max() > 0.3
    assert np.abs(one - two).max() < 1e-10, np.abs(one - two).max()


# ---- lossless: the reduced dynamics by another route -------------------------------------------------------------

def test_lossless_finger_matches_an_ode_of_the_reduced_dynamics():
    """Rigid tendons, rotors reflected through R_m⁻¹ K, motor torques to the joints by Kᵀ R_m⁻¹ (virtual work):
    over 50 ms of a falling, flailing finger (0.5 rad) the simulator is within 2.4e-4 rad of the oracle's integration of
    the reduced dynamics at 10 kHz and converges to it at first order (1.2e-4 rad at 20 kHz, measured); the
    oracle without the rotors is 0.8 rad away."""
    dev = _finger()
    h = np.array([1 / 12, 1 / 5, 7 / 8, 1.0])     # the internal tension (file header): 10 N of it, plus sines
    errs = []
    for rate in (10_000.0, 20_000.0):
        n = int(0.05 * rate)
        ff = R_M * 10.0 * h + _motor_torques(4, n, 0.002, 0.0, rate)
        log, _, _ = _run_torque(dev, ff, Q0_FINGER, friction=False, rate=rate)
        assert np.abs(log["q_joint"] - Q0_FINGER).max() > 0.3
        errs.append(np.abs(log["q_joint"] - _ode_oracle(dev, ff, Q0_FINGER, rate=rate)).max())
        # the motors follow the joints through the routing: q_m = R_m⁻¹ K q
        np.testing.assert_allclose(log["q_motor"], log["q_joint"] @ (K_FINGER / R_M).T, atol=1e-12)
        if rate == 10_000.0:
            q_no_rotor = _ode_oracle(dev, ff, Q0_FINGER, with_rotor=False, rate=rate)
            assert np.abs(log["q_joint"] - q_no_rotor).max() > 100 * errs[0]
    assert errs[0] < 5e-4, errs
    assert 0.4 < errs[1] / errs[0] < 0.6, errs     # first order in the step


@pytest.mark.parametrize("n", range(1, 5))
def test_generated_lossless_matches_the_ode(tmp_path, n):
    dev = _generated(tmp_path, n)
    steps = 1500
    peak = min(t.motor.peak_torque for t in dev.transmissions)
    ff = _motor_torques(n + 1, steps, 0.05 * peak, 0.05 * peak)
    q0 = np.zeros(n)
    log, m, _ = _run_torque(dev, ff, q0, friction=False)
    assert m.nm == n + 1 and not np.any(m.tendons.tau0) and not np.any(m.tendons.nu)
    err = np.abs(log["q_joint"] - _ode_oracle(dev, ff, q0)).max()
    assert err < 5e-4 * max(1.0, np.abs(log["q_joint"] - q0).max()), err


# ---- with the branch losses: energy balance from the logs --------------------------------------------------------

def _run_pid(dev, q0, amp, freq_hz, seconds, rate=RATE):
    """Joint PID at the integration rate (4 Hz bandwidth), ideal sensors, tracking q0 + amp sin(2π f t): gentle
    motions, the tensions allocated by tendons.hpp (floors = pretension)."""
    from tendyn.sim.experiments import pid_gains

    m = sim_model(dev, rate_hz=rate, control_hz=rate, sensors=False)
    m.mode = _core.ControlMode.JointPID
    m.kp, m.kd, m.ki = pid_gains(m, dev, q0, 4.0)
    d = _core.SimData(m)
    d.reset(np.asarray(q0, float), 0)
    n = int(seconds * rate)
    t = np.arange(n) / rate
    w = 2 * np.pi * np.asarray(freq_hz)
    q_ref = q0 + amp * np.sin(w * t[:, None])
    qd_ref = amp * w * np.cos(w * t[:, None])
    return run_log(m, d, q_ref, qd_ref, np.zeros_like(q_ref), np.zeros_like(q_ref), 1), m, d


def _energy_balance(dev, log, K, r_m, rotor, tau0, nu, rate=RATE):
    """(work of the motors, ΔE, dissipation) [J] from the logged signals: W = Σ C_m·q̇_m⁺ h, E = ½ q̇ᵀ M q̇ +
    ½ Σ I_m q̇_m² + U (Pinocchio), D = Σ h Σ_ib (τ0_ib |Ṡ_ib| + ν_ib Ṡ_ib²) at the end-of-step velocities."""
    h = 1.0 / rate
    compiled = compile_device(dev)
    pm = compiled.pinocchio_model
    pd = pm.createData()
    q, qd = log["q_joint"], log["qd_joint"]
    qdm = qd @ (K / r_m[:, None]).T                # the motors from the joints, computed here
    peaks = np.array([t.motor.peak_torque for t in dev.transmissions])
    C = np.clip(log["torque_motor_cmd"], -peaks, peaks)   # ideal sensors: the command, saturated, is applied
    work = h * np.sum(C[:-1] * qdm[1:])
    m, n = K.shape
    diss = 0.0
    for i in range(m):
        for b in range(n):
            if tau0[i, b] == 0.0 and nu[i, b] == 0.0:
                continue
            sdot = qd[1:, b:] @ K[i, b:]           # Ṡ_ib = Σ_{l ≥ b} K_il q̇_l
            diss += h * np.sum(tau0[i, b] * np.abs(sdot) + nu[i, b] * sdot**2)

    def energy(k):
        e = pin.computeKineticEnergy(pm, pd, q[k], qd[k]) + pin.computePotentialEnergy(pm, pd, q[k])
        return e + 0.5 * np.sum(rotor * qdm[k] ** 2)
    return work, energy(len(q) - 1) - energy(0), diss


def test_finger_energy_balance_with_branch_losses():
    """Work of the motor torques = change of kinetic + potential energy + branch dissipation Σ f Ṡ ≥ 0
    (τ0 |Ṡ| + ν Ṡ², S0 eq. 12), from the logs of 2 s of joint-PID tracking. The semi-implicit step adds its own
    O(h) numerical damping (½ Δvᵀ M Δv per step): measured residual 1.8e-4 of the work at 10 kHz, halving at
    20 kHz; the dissipation is 56 % of the work, so a flipped or dropped loss term breaks the balance by far more."""
    dev = _finger()
    K, r_m, rotor, tau0, nu = _device_arrays(dev)
    np.testing.assert_allclose(K, K_FINGER, atol=1e-15)
    resid = []
    for rate in (RATE, 2 * RATE):
        log, m, d = _run_pid(dev, Q0_FINGER, np.array([0.3, 0.3, 0.2]), [0.7, 1.1, 1.3], 2.0, rate=rate)
        work, dE, diss = _energy_balance(dev, log, K, r_m, rotor, tau0, nu, rate=rate)
        assert diss > 0.3 * work
        resid.append(work - dE - diss)
        assert abs(resid[-1]) < 1e-3 * abs(work), (work, dE, diss)
        # the simulator's own diagnostics agree with the oracle's sums
        assert d.dissipated == pytest.approx(diss, rel=1e-3)
        assert d.work_motor == pytest.approx(work, rel=1e-3)
        if rate == RATE:
            # break the oracle (as a broken simulator would): ν with the wrong sign, or τ0 dropped
            for t0, v in ((tau0, -nu), (0 * tau0, nu)):
                _, _, wrong = _energy_balance(dev, log, K, r_m, rotor, t0, v, rate=rate)
                assert abs(work - dE - wrong) > 100 * abs(resid[0])
    assert 0.3 < resid[1] / resid[0] < 0.7, resid      # the residual is the step's: first order in h


@pytest.mark.parametrize("n", range(1, 5))
def test_generated_energy_balance(tmp_path, n):
    """Generated N+1 devices (no gravity, so the joint PID keeps the motions gentle): residual below 1 % of the work
    and 10 % of the branch dissipation (measured 0.1–0.6 % of the work)."""
    dev = _generated(tmp_path, n, gravity=False)
    log, _, _ = _run_pid(dev, np.zeros(n), 0.2 * np.ones(n), 0.5 + 0.2 * np.arange(n), 1.0)
    K, r_m, rotor, tau0, nu = _device_arrays(dev)
    work, dE, diss = _energy_balance(dev, log, K, r_m, rotor, tau0, nu)
    assert diss > 0.05 * work
    assert abs(work - dE - diss) < min(1e-2 * abs(work), 0.1 * diss), (work, dE, diss)


# ---- the tendon feedforward of tendons.hpp cancels the simulated losses ------------------------------------------

def _reference(n_steps, q0, v, a, w):
    t = np.arange(n_steps) / RATE
    q = q0 + v * t[:, None] + a * np.sin(w * t)[:, None]
    qd = v + a * w * np.cos(w * t)[:, None]
    qdd = -a * w**2 * np.sin(w * t)[:, None]
    return q, qd, qdd


def test_tendon_feedforward_cancels_the_branch_losses_in_simulation():
    """Open loop: motor torques C_m = R_m t + I_m q̈_m,ref with the tensions t of tendons.hpp's feedforward of the
    rigid-body torque along a reference whose branches all slide (every Ṡ keeps its sign). With the losses at the
    reference velocity (S0 eq. 12) the finger follows the reference (measured 1.2e-5 rad over 0.2 s); with the
    lossless feedforward it drifts away (measured 0.12 rad)."""
    dev = _finger()
    compiled = compile_device(dev)
    pm = compiled.pinocchio_model
    pd = pm.createData()
    n = 2000
    v = np.array([0.5, 0.4, 0.3])
    q_ref, qd_ref, qdd_ref = _reference(n, Q0_FINGER, v, a=np.array([0.05, 0.04, 0.03]), w=6.0)
    sdot = np.array([[qd_ref[k, b:] @ K_FINGER[i, b:] for i in range(4) for b in range(3)] for k in range(0, n, 50)])
    assert np.all(np.abs(sdot[:, [0, 3, 4, 6, 7, 8]]) > 1e-3)   # the flexors' branches slide
    tendons = Tendons.from_device(dev)
    runs = {}
    for compensate in (True, False):
        ff = np.empty((n, 4))
        for k in range(n):
            # the simulator evaluates the forces at the start of each step and holds the command over it
            tk = k / RATE
            qk = Q0_FINGER + v * tk + np.array([0.05, 0.04, 0.03]) * np.sin(6.0 * tk)
            qdk = v + np.array([0.05, 0.04, 0.03]) * 6.0 * np.cos(6.0 * tk)
            qddk = -np.array([0.05, 0.04, 0.03]) * 36.0 * np.sin(6.0 * tk)
            tau = pin.rnea(pm, pd, qk, qdk, qddk)
            out = tendons.feedforward(tau, qdk if compensate else None)
            ff[k] = out.motor_torque + ROTOR * (K_FINGER @ qddk) / R_M
        log, _, _ = _run_torque(dev, ff, q_ref[0], qd0=qd_ref[0])
        runs[compensate] = np.abs(log["q_joint"] - q_ref).max()
    assert runs[True] < 1e-4, runs
    assert runs[False] > 1000 * runs[True], runs


def test_joint_pid_with_loss_compensation_tracks_better():
    """The joint PID of the twin allocates its torque to tensions ≥ the floors (tendons.hpp); with
    tendon_loss_compensation the branch losses at the reference velocity are added (S0 eq. 12 in the loop):
    the RMS tracking error falls by half (measured 0.161 → 0.077 rad on a 1 Hz, 0.2–0.3 rad reference)."""
    dev = _finger()
    from tendyn.sim.experiments import pid_gains

    n = 6000
    t = np.arange(n) / RATE
    amp = np.array([0.3, 0.3, 0.2])
    q_ref = Q0_FINGER + amp * np.sin(2 * np.pi * 1.0 * t)[:, None]
    qd_ref = amp * 2 * np.pi * np.cos(2 * np.pi * 1.0 * t)[:, None]
    rms = {}
    for comp in (False, True):
        m = sim_model(dev, rate_hz=RATE, control_hz=1000.0, sensors=False)
        m.mode = _core.ControlMode.JointPID
        m.kp, m.kd, m.ki = pid_gains(m, dev, Q0_FINGER, 4.0)
        m.velocity_cutoff_hz = 100.0
        m.tendon_loss_compensation = comp
        d = _core.SimData(m)
        d.reset(Q0_FINGER, 0)
        log = run_log(m, d, q_ref, qd_ref, np.zeros((n, 3)), np.zeros((n, 3)), 10)
        err = log["q_joint"] - q_ref[::10]
        rms[comp] = float(np.sqrt(np.mean(err[len(err) // 3:] ** 2)))
        # every tendon's motor pulls at least its floor's share: tensions ≥ 2 N at the motors, up to the loss
        assert np.all(log["torque_motor_cmd"] / R_M > 2.0 - 1e-9)
    assert rms[True] < 0.6 * rms[False], rms


# ---- the command line: what runs, what refuses -------------------------------------------------------------------

def test_simulate_runs_the_n_plus_one_experiments_and_refuses_the_others(tmp_path, capsys):
    for exp, extra in (("exciting", ["--duration", "1"]), ("constant-velocity", ["--speeds", "2"])):
        out = tmp_path / f"{exp}.csv"
        assert main(["simulate", "tendon_finger", exp, "--quiet", "--out", str(out), *extra]) == 0, exp
        head = out.read_text().splitlines()[1]    # the columns, after the metadata line
        assert "torque_motor_cmd_4" in head and "q_motor_4" in head
    capsys.readouterr()
    for argv in (["simulate", "tendon_finger", "blocked-link", "--quiet", "--out", str(tmp_path / "b.csv")],
                 ["simulate", "tendon_finger", "constant-velocity", "--strategy", "S1", "--quiet", "--out",
                  str(tmp_path / "s1.csv")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "N+1" in err, err


def test_statics_compensator_exports_still_refuse_n_plus_one(tmp_path, capsys):
    dev = _finger()
    for call in (lambda: Transmission.from_device(dev), lambda: compile_device(dev).transmission):
        with pytest.raises(DeviceError) as exc:
            call()
        assert exc.value.field == "device.routing" and "N+1" in exc.value.problem
    for argv in (["export", "mjcf", "tendon_finger", "--out", str(tmp_path / "x.xml")],
                 ["export", "transmission", "tendon_finger", "--out", str(tmp_path / "x.model")],
                 ["plan", "exciting", "tendon_finger", "--out", str(tmp_path / "p.csv")]):
        assert main(argv) == 2, argv
        assert "N+1" in capsys.readouterr().err


# ---- β, the tension-proportional loss of S0 eq. 11, on N+1 tendons ------------------------------------------------

BETA = 0.01


def _finger_with_beta(tmp_path, beta=BETA):
    """The finger with β on every branch of every tendon (the file's friction entries get ``beta``)."""
    text = bundled("tendon_finger").read_text(encoding="utf-8")
    text = text.replace("nu = 0.5}", f"nu = 0.5, beta = {beta}}}").replace("nu = 0.4}", f"nu = 0.4, beta = {beta}}}")
    text = text.replace("nu = 0.3}", f"nu = 0.3, beta = {beta}}}")
    p = tmp_path / "finger_beta.toml"
    p.write_text(text, encoding="utf-8")
    return load_device(p)


def test_beta_feedforward_obeys_the_branch_law_everywhere(tmp_path):
    """tendons.hpp with β: along every sliding branch the tension climbed toward the motor satisfies
    y − x = sgn(Ṡ)(τ0 + β max(|x|, |y|)) + ν Ṡ (S0 eq. 11 with eq. 12, motion sign restored: ERRATA), restated here;
    every joint is in equilibrium τ_j = Σ_i K_ij T_ij (S0 eq. 4); every tension ≥ its floor, one touching."""
    dev = _finger_with_beta(tmp_path)
    K, _, _, tau0, nu = _device_arrays(dev)
    beta = np.where(tau0 > 0, BETA, 0.0)
    assert np.count_nonzero(beta) == 9
    td = Tendons.from_device(dev)
    np.testing.assert_array_equal(np.array(td.model.beta), beta)
    rng = np.random.default_rng(3)
    for _ in range(30):
        tau = rng.uniform(-0.05, 0.05, 3)
        qd = rng.uniform(-2.0, 2.0, 3)
        out = td.feedforward(tau, qd)
        assert td._data.iterations >= 1
        T = out.tension_joint                             # (m, n) at each joint, 0 past the tendon's end
        last = [0, 1, 2, 2]
        for i in range(4):
            for b in range(last[i] + 1):
                x = T[i, b]
                y = out.tension[i] if b == 0 else T[i, b - 1]
                s = qd[b:last[i] + 1] @ K[i, b:last[i] + 1]
                want = np.sign(s) * (tau0[i, b] + beta[i, b] * max(abs(x), abs(y))) + nu[i, b] * s
                assert y - x == pytest.approx(want, abs=1e-11)
        np.testing.assert_allclose(np.einsum("ij,ij->j", K, T), tau, atol=1e-11)
        lows = [min(out.tension[i], T[i, : last[i] + 1].min()) for i in range(4)]
        assert min(lows) == pytest.approx(2.0, abs=1e-9) and all(lo >= 2.0 - 1e-9 for lo in lows)
    # the law with β dropped is not what the feedforward computes (the oracle can fail): the extensor's branch at
    # joint 2 (x at joint 3, y at joint 2) differs from τ0 sgn(Ṡ) + ν Ṡ by β max(|x|, |y|) ≥ 0.1 N
    qd = np.ones(3)
    out = td.feedforward(np.array([0.02, -0.01, 0.01]), qd)
    x, y = out.tension_joint[3, 2], out.tension_joint[3, 1]
    s = K[3, 2] * qd[2]
    assert abs((y - x) - (np.sign(s) * tau0[3, 2] + nu[3, 2] * s)) > 0.1 * BETA * 2.0


def test_beta_losses_cancelled_in_simulation(tmp_path):
    """The twin with β = 0.01 on every branch (branch bounds τ0 + β max(|T_up|, |T_down|), the tensions along each
    tendon from its motor at the last step) against the feedforward of tendons.hpp with β, open loop as above:
    knowing β the finger stays within 1.8e-2 rad of the reference over 0.2 s (measured), the feedforward without β
    (τ0 and ν only) drifts 0.12 rad. Not yet the 1.2e-5 rad of τ0 and ν alone: the gap between the twin's
    lagged-tension β bound and the feedforward's exact branch law is open (docs/device-file.md)."""
    dev = _finger_with_beta(tmp_path)
    compiled = compile_device(dev)
    pm = compiled.pinocchio_model
    pd = pm.createData()
    n = 2000
    v, a, w = np.array([0.5, 0.4, 0.3]), np.array([0.05, 0.04, 0.03]), 6.0
    t = np.arange(n) / RATE
    q_ref = Q0_FINGER + v * t[:, None] + a * np.sin(w * t)[:, None]
    qd_ref = v + a * w * np.cos(w * t)[:, None]
    with_beta = Tendons.from_device(dev)
    no_beta = Tendons.from_device(_finger())
    errs = {}
    for name, tendons in (("beta", with_beta), ("no beta", no_beta)):
        ff = np.empty((n, 4))
        for k in range(n):
            tk = k / RATE
            qk = Q0_FINGER + v * tk + a * np.sin(w * tk)
            qdk = v + a * w * np.cos(w * tk)
            qddk = -a * w * w * np.sin(w * tk)
            ff[k] = tendons.feedforward(pin.rnea(pm, pd, qk, qdk, qddk), qdk).motor_torque + \
                ROTOR * (K_FINGER @ qddk) / R_M
        log, m, _ = _run_torque(dev, ff, q_ref[0], qd0=qd_ref[0])
        assert np.count_nonzero(np.array(m.tendons.beta)) == 9
        errs[name] = np.abs(log["q_joint"] - q_ref).max()
    assert errs["beta"] < 0.03, errs
    assert errs["no beta"] > 5 * errs["beta"], errs
