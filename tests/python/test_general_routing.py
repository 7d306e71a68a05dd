"""General cable routing (issue 19, items 1, 2, 5): differentials, signed and zero radii, antagonistic pairs (2N),
N+1 tendons; losses along every branch of them. Oracles are written by hand here (the matrices of the bundled
examples, the tensions of a differential with losses), never computed by the code under test."""

import numpy as np
import pytest

from tendyn import _core
from tendyn.cli import main
from tendyn.device import DeviceError, load_device
from tendyn.device.routing_checks import NotSeparable, require_separable, tendon_coupling
from tendyn.devices import bundled
from tendyn.devices.generate import cable_device_toml, write_cable_device
from tendyn.transmission import Transmission


def _write(tmp_path, text, name="dev.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# ---- item 5: bundled examples against hand-derived matrices --------------------------------------------------

def test_differential_wrist_matches_the_hand_derived_matrices():
    """diff_wrist.toml: K written by hand from the pulleys, and its actuator->joint map derived by hand:
    q1 = r_m q_m1 / 0.24; q2 = (r_m q_m2 - 0.015 q1) / 0.24; the wrist q3 = (S3 + S4) / 0.04, q4 = (S3 - S4) / 0.04
    with S3 = r_m q_m3 - 0.015 q1 + 0.015 q2, S4 = r_m q_m4 - 0.015 q1 - 0.015 q2 (r_m = 0.01 m)."""
    dev = load_device(bundled("diff_wrist"))
    K_hand = np.array([[0.24, 0.0, 0.0, 0.0],
                       [0.015, 0.24, 0.0, 0.0],
                       [0.015, -0.015, 0.02, 0.02],
                       [0.015, 0.015, 0.02, -0.02]])
    np.testing.assert_allclose(dev.routing_arrays()["K"], K_hand, rtol=0, atol=1e-15)
    q1 = 0.01 / 0.24
    q2_m1, q2_m2 = -0.015 * q1 / 0.24, 0.01 / 0.24
    joint_from_motor_hand = np.array([
        [q1, 0.0, 0.0, 0.0],
        [q2_m1, q2_m2, 0.0, 0.0],
        [-0.03 * q1 / 0.04, 0.0, 0.25, 0.25],            # the q2 terms of S3 and S4 cancel
        [0.03 * q2_m1 / 0.04, 0.03 * q2_m2 / 0.04, 0.25, -0.25],   # the q1 terms cancel
    ])
    tr = Transmission.from_device(dev)
    np.testing.assert_allclose(tr.matrices()["joint_from_motor_position"], joint_from_motor_hand, rtol=1e-12, atol=1e-15)
    assert not tr.model.serial
    assert list(tr.model.block_begin) == [0, 1, 2, 2] and list(tr.model.last_joint) == [0, 1, 3, 3]


def test_antagonistic_pair_matches_the_hand_derived_matrices():
    """antagonistic_pair.toml: the net-tension K [[0.03, 0], [0.012, 0.025]]; the pair's losses as one row
    (tau0 = 2 τ0 + 2 β P, nu = 2 ν, beta = 0: 2·0.4 + 2·0.01·150 = 3.8 N, 6 N s/m); minimum pretension
    peak / (2 r_m) = 2.5 / 0.02 = 125 N (the file sets 150 N)."""
    dev = load_device(bundled("antagonistic_pair"))
    arr = dev.routing_arrays()
    np.testing.assert_allclose(arr["K"], [[0.03, 0.0], [0.012, 0.025]], atol=1e-15)
    assert arr["tau0"][0, 0] == pytest.approx(3.8) and arr["nu"][0, 0] == pytest.approx(6.0)
    assert arr["tau0"][1, 1] == pytest.approx(2 * 0.3 + 2 * 0.01 * 150) and arr["beta"].max() == 0.0
    # the four cables one by one (2N): closure with every cable taut; the min pretension over |τ| <= (1, 0.5) N m:
    # u2 = τ2 / 0.025 <= 20 N, u1 = (τ1 - 0.012 u2) / 0.03 <= (1 + 0.24) / 0.03 N; each cable carries P ± u/2
    cables = np.array([[0.03, 0.0], [-0.03, 0.0], [0.012, 0.025], [-0.012, -0.025]])
    c = tendon_coupling(cables, torque_limits=[1.0, 0.5])
    assert c.rank == 2 and c.closure
    assert c.min_pretension == pytest.approx((1.0 + 0.24) / 0.03 / 2, rel=1e-9)
    np.testing.assert_allclose(c.pattern, [1, 1, 1, 1], atol=1e-9)


def test_antagonistic_pretension_below_the_minimum_names_the_transmission(tmp_path):
    text = bundled("antagonistic_pair").read_text().replace("pretension = 150.0               # N per cable [ASSUMPTION]\nfriction = [{tau0 = 0.4",
                                                            "pretension = 100.0\nfriction = [{tau0 = 0.4")
    with pytest.raises(DeviceError, match=r"transmissions\[1\]\.pretension: must be >= 125 N .*antagonistic pair"):
        load_device(_write(tmp_path, text))


def test_n_plus_one_tendons_by_hand():
    """N+1 (3 cables, 2 joints): Kᵀ h = 0 with K = [[1, 1], [1, -1], [-1, 0]] r gives h = (1, 1, 2)/2 > 0
    (every cable can be kept taut); K = [[1, 0], [0, 1], [1, 1]] r has h = (1, 1, -1): no closure."""
    r = 0.01
    c = tendon_coupling(r * np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 0.0]]), torque_limits=[0.2, 0.1])
    assert c.rank == 2 and c.closure
    np.testing.assert_allclose(c.pattern, [0.5, 0.5, 1.0], atol=1e-9)
    # hand: the columns of K are orthogonal (norms² 3r², 2r²), so pinv(Kᵀ) τ = (2τ1 + 3τ2, 2τ1 − 3τ2, −2τ1)/(6r);
    # t = that + P h ≥ 0 on every vertex of the box needs P ≥ (2·0.2 + 3·0.1)/(6r)/0.5 (cables 1 and 2)
    assert c.min_pretension == pytest.approx((2 * 0.2 + 3 * 0.1) / (6 * r) / 0.5, rel=1e-9)
    bad = tendon_coupling(r * np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
    assert bad.rank == 2 and not bad.closure and bad.min_pretension is None


# ---- item 1: what the loader now accepts, and what it refuses naming the transmission ------------------------

_TWO = """schema = 1
[device]
name = "two"
[kinematics]
convention = "dh"
gravity = [0.0, -9.81, 0.0]
[[kinematics.joints]]
name = "j1"
a = 0.2
alpha = 0.0
d = 0.0
lower = -1.5
upper = 1.5
mass = 0.5
com = [-0.1, 0.0, 0.0]
inertia = [0.002, 0.002, 0.002, 0.0, 0.0, 0.0]
[[kinematics.joints]]
name = "j2"
a = 0.15
alpha = 0.0
d = 0.0
lower = -1.5
upper = 1.5
mass = 0.3
com = [-0.07, 0.0, 0.0]
inertia = [0.001, 0.001, 0.001, 0.0, 0.0, 0.0]
"""
_MOTOR = """[transmissions.motor]
torque_constant = 0.1
rotor_inertia = 4e-5
continuous_torque = 1.0
peak_torque = 3.0
[transmissions.sensors]
encoder_counts = 16384
current_noise = 0.02
"""


def _trans(name, joint, crosses, radii, driven, branches, extra=""):
    fr = ", ".join(["{tau0 = 0.5, nu = 4.0, beta = 0.02}"] * branches)
    return (f'[[transmissions]]\nname = "{name}"\njoint = {joint}\nmotor_radius = 0.01\ncrosses = {crosses}\n'
            f"crossed_radii = {radii}\ndriven_radius = {driven}\n{extra}friction = [{fr}]\n" + _MOTOR)


def test_zero_diagonal_routing_is_accepted_where_invertible(tmp_path):
    """A surgical-wrist style coupling with a zero diagonal: t1 drives joint 1 with no pulley there (driven_radius
    0) and wraps joint 2; t2 wraps joint 1 and drives joint 2 with a negative radius. K = [[0, 0.02], [0.03, -0.01]]
    by hand; q = K⁻¹ R_m q_m: q2 = 0.01 q_m1 / 0.02, q1 = (0.01 q_m2 + 0.01 q2) / 0.03."""
    text = _TWO + _trans("t1", 1, [2], [0.02], 0.0, 2) + _trans("t2", 2, [1], [0.03], -0.01, 2)
    dev = load_device(_write(tmp_path, text))
    np.testing.assert_allclose(dev.routing_arrays()["K"], [[0.0, 0.02], [0.03, -0.01]], atol=1e-15)
    J = Transmission.from_device(dev).matrices()["joint_from_motor_position"]
    np.testing.assert_allclose(J, [[0.01 * 0.5 / 0.03, 0.01 / 0.03], [0.5, 0.0]], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("strategy", ["S2", "S1"])
def test_plan_refuses_a_zero_diagonal_transmission_in_one_line(tmp_path, capsys, strategy):
    """`tendyn plan` on the zero-diagonal wrist: the stroke is planned on the driven joint (travel / G[j, j]), which
    t1 does not wrap; a one-line refusal naming t1, exit 2 (was NaN and an internal error). t2 still plans."""
    text = _TWO + _trans("t1", 1, [2], [0.02], 0.0, 2) + _trans("t2", 2, [1], [0.03], -0.01, 2)
    dev = _write(tmp_path, text)
    out = tmp_path / "r.csv"
    assert main(["plan", "constant-velocity", str(dev), "--transmission", "1", "--strategy", strategy,
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "transmission t1 does not wrap joint 1" in err, err
    assert not out.exists()
    assert main(["plan", "constant-velocity", str(dev), "--transmission", "2", "--strategy", strategy,
                 "--out", str(out)]) == 0


def test_the_issues_refused_routings_now_load(tmp_path):
    """The messages of issue 19 (negative driven radius; a cable crossing a joint after the one it drives) are
    gone: both are routings of real differentials."""
    text = _TWO + _trans("t1", 1, [2], [0.42], 0.42, 2) + _trans("t2", 2, [1], [0.42], -0.42, 2)
    dev = load_device(_write(tmp_path, text))
    np.testing.assert_allclose(dev.routing_arrays()["K"], [[0.42, 0.42], [0.42, -0.42]])


@pytest.mark.parametrize("t1,t2,match", [
    # identical rows: the second transmission depends on the first
    (("t1", 1, [2], [0.02], 0.02, 2), ("t2", 2, [1], [0.02], 0.02, 2),
     r"transmissions\[2\]: the routing is singular: the row of K of transmission t2"),
    # a zero driven radius that nothing else makes up for
    (("t1", 1, [], [], 0.0, 1), ("t2", 2, [1], [0.02], 0.03, 2),
     r"transmissions\[1\]\.driven_radius: must be nonzero here \(got 0.0\): a zero driven radius makes the routing "
     r"singular"),
    # a reducer on a cable that goes on past its driven joint
    (("t1", 1, [2], [0.02], 0.02, 2, "reducer_ratio = 4.0\n"), ("t2", 2, [1], [0.02], -0.02, 2),
     r"transmissions\[1\]\.reducer_ratio: must be 1 .*differential"),
    # a self-locking reducer outside a serial routing
    (("t1", 1, [], [], 0.03, 1), ("t2", 2, [1], [0.02], -0.02, 2, "reducer_ratio = 4.0\nreducer_efficiency = 0.4\n"),
     r"transmissions\[2\]\.reducer_efficiency: must be > 0.5"),
    # friction entries must reach the last joint the cable wraps
    (("t1", 1, [2], [0.02], 0.02, 1), ("t2", 2, [1], [0.02], -0.02, 2),
     r"transmissions\[1\]\.friction: must have exactly 2 entries, .*wraps joints up to 2"),
])
def test_bad_general_routings_name_the_transmission(tmp_path, t1, t2, match):
    text = _TWO + _trans(*t1) + _trans(*t2)
    with pytest.raises(DeviceError, match=match):
        load_device(_write(tmp_path, text))


# ---- item 2: losses along a differential ----------------------------------------------------------------------

def _pair_model(**losses):
    r = 0.02
    K = np.array([[r, r], [r, -r]])
    return Transmission.from_arrays([0.01, 0.01], K, **losses)


def test_differential_with_losses_by_hand():
    """K = [[r, r], [r, -r]], τ0 = 0.3 N on branch 1 of both cables, β = 0.1 on branch 0 of cable 0, q̇ = (1, 0.5):
    Ṡ(cable 0) = (0.03, 0.01), Ṡ(cable 1) = (0.01, -0.01) m/s. At joint 1 the cables carry their end tensions
    t0, t1; at joint 0, t0 + 0.3 and t1 − 0.3, so τ = (r (t0 + t1), r (t0 − t1)) and the motor tensions are
    (t0 + 0.3)/(1 − 0.1) (β on the driving tension, sliding with the pull) and t1 − 0.3."""
    tau0 = np.array([[0.0, 0.3], [0.0, 0.3]])
    beta = np.array([[0.1, 0.0], [0.0, 0.0]])
    tr = _pair_model(tau0=tau0, beta=beta)
    tau, qd = np.array([0.5, -0.2]), np.array([1.0, 0.5])
    res = tr.feedforward(tau, qd)
    t0, t1 = (0.5 - 0.2) / 0.04, (0.5 + 0.2) / 0.04
    np.testing.assert_allclose(res.torque_motor, 0.01 * np.array([(t0 + 0.3) / 0.9, t1 - 0.3]), rtol=1e-12)
    # forward is its exact inverse while every branch slides
    np.testing.assert_allclose(tr.forward(res.torque_motor, qd).torque_joint, tau, rtol=1e-12)


def test_differential_lossless_virtual_work_and_losses_dissipate():
    """Lossless: q̇ᵀτ_J = q̇_mᵀC_m (S0 eq. 5); with losses the motors put in more power than the joints take
    (never active), on random states of the bundled differential-wrist arm."""
    dev = load_device(bundled("diff_wrist"))
    lossless, lossy = Transmission.from_device(dev, losses=False), Transmission.from_device(dev)
    rng = np.random.default_rng(3)
    for _ in range(200):
        tau, qd = rng.normal(size=4), rng.normal(size=4)
        qd_m = lossless.matrices()["motor_from_joint_position"] @ qd
        c0 = lossless.feedforward(tau, qd).torque_motor
        assert qd_m @ c0 == pytest.approx(qd @ tau, rel=1e-10, abs=1e-12)
        c = lossy.feedforward(tau, qd).torque_motor
        assert qd_m @ c >= qd @ tau - 1e-12


def test_differential_stuck_branch_passes_the_tension():
    """q̇ = (1, -1) on the pair: cable 0's branch 0 slides at r(1 - 1) = 0: stuck, it passes its tension."""
    tr = _pair_model(tau0=np.full((2, 2), 0.4))
    res = tr.feedforward(np.array([0.3, 0.1]), np.array([1.0, -1.0]))
    assert res.stuck[0, 0] == 1 and res.tension[0, 0] == pytest.approx(res.tension_motor[0])


def test_s0_identification_refuses_a_differential_clearly(tmp_path, capsys):
    """What S0's method cannot separate (docs/compensator.md): decomposition and identify-friction refuse a
    coupled routing with one line naming the coupled transmissions."""
    dev = load_device(bundled("diff_wrist"))
    with pytest.raises(NotSeparable, match=r"wrist_a, wrist_b are coupled"):
        require_separable(dev, "the loss decomposition")
    require_separable(load_device(bundled("lexos")), "x")   # serial: nothing to refuse
    f = tmp_path / "f.json"
    f.write_text("{}")
    assert main(["decompose", str(bundled("diff_wrist")), str(f)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "serial routing" in err and "wrist_a, wrist_b" in err


# ---- generated differential devices through the commands ------------------------------------------------------

def test_generated_differential_device(tmp_path):
    """tendyn.devices.generate(differential=True): pairs at joints 2-3 and 6-7 of a 7-joint arm, K invertible,
    the blocks found; without the option the device is the serial one it always was."""
    dev = load_device(_write(tmp_path, cable_device_toml(7, differential=True, seed=4)))
    K = dev.routing_arrays()["K"]
    assert K[1, 2] == K[1, 1] == K[2, 1] == -K[2, 2] and K[5, 6] == K[5, 5] == -K[6, 6]
    m = Transmission.from_device(dev).model
    assert list(m.block_begin) == [0, 1, 1, 3, 4, 5, 5] and not m.serial
    serial = load_device(_write(tmp_path, cable_device_toml(7, seed=4), "s.toml"))
    assert np.all(np.triu(serial.routing_arrays()["K"], 1) == 0)


def test_plan_simulate_compensator_on_a_generated_differential(tmp_path, capsys):
    """plan → simulate (the twin with the differential's losses in the loop) → export transmission → the
    compensator built from the device's losses, on a generated 3-joint arm with a wrist differential."""
    from tendyn.control import Compensator
    from tendyn.io import read_log

    dev = write_cable_device(tmp_path, 3, differential=True, seed=5)
    ref, log = tmp_path / "ref.csv", tmp_path / "t3.parquet"
    assert main(["plan", "constant-velocity", str(dev), "--transmission", "3", "--out", str(ref)]) == 0
    assert main(["simulate", str(dev), "constant-velocity", "--transmission", "3", "--quiet", "--out", str(log)]) == 0
    lg = read_log(log)
    assert np.all(np.isfinite(lg.stack("q_motor_")))
    assert main(["export", "transmission", str(dev), "--out", str(tmp_path / "x.model")]) == 0
    assert main(["identify-friction", str(dev), str(log), "--out", str(tmp_path / "f.json")]) == 2
    capsys.readouterr()
    comp = Compensator.from_device(load_device(dev))
    out = comp.cycle(np.array([0.1, 0.2, -0.1]), np.array([0.1, -0.2, 0.05]))
    assert out.shape == (3,) and np.all(np.isfinite(out))


@pytest.mark.parametrize("lossy", (False, True))
def test_differential_reducer_direction_by_hand(lossy):
    """Issue 34 blind area (the reducer's direction in the differential-pair table, losses.hpp take_pair_table):
    K = [[r, r], [r, -r]], a reducer η_d = 0.8 on joint 1 (cable 1's driven pulley; cable 0 wraps on: none at 0).
    Joint 1 driven (τ1 q̇1 > 0): τ1 = r t0 − η_d r t1; back-driven: the factor is η_d/(2η_d − 1) (S0 eqs. 9–10);
    τ0 = r (t0 + t1). Lossy: τ0 = 0.3 N on branch 1 of both cables adds sgn(Ṡ_i1) 0.3 N to each motor tension.
    Both power directions are checked, so swapping the two factors fails (planted in take_pair_table: fails)."""
    r, eta = 0.02, 0.8
    K = np.array([[r, r], [r, -r]])
    kw = {"tau0": np.array([[0.0, 0.3], [0.0, 0.3]])} if lossy else {}
    tr = Transmission.from_arrays([0.01, 0.01], K, reducer_efficiency=[1.0, eta], **kw)
    tau = np.array([0.5, -0.2])
    for qd in (np.array([1.0, 0.5]), np.array([1.0, -0.5])):
        e = eta if tau[1] * qd[1] > 0 else eta / (2 * eta - 1)
        t = np.linalg.solve(np.array([[r, r], [r, -r * e]]), tau)
        if lossy:
            t = t + 0.3 * np.sign(K[:, 1] * qd[1])
        np.testing.assert_allclose(tr.feedforward(tau, qd).torque_motor, 0.01 * t, rtol=1e-12)
