"""Online friction tracking in the compensator (include/tendyn/friction_tracking.hpp): the RLS recurrences, its
gates and bounds, the model-file section, and the L-EXOS twin with its friction drifting ±30 % (C46 beyond the
paper). The tracker never reads the twin's losses: it sees encoder readings and its own commands only."""

import numpy as np
import pytest

from tendyn.control import Compensator, dissipation_bound
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.pipelines.s0_compensation import hand_run
from tendyn.pipelines.tracking import FrictionDrift, self_test_run


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


def _motion(comp, steps, rng, torque_scale=0.5, speed=8.0):
    """Synthetic encoder motion (motor speeds about ``speed`` rad/s, slow speed changes) with random wanted
    joint torques; yields after each cycle."""
    n, T = comp.n, comp.model.period()
    phase = rng.uniform(0, 2 * np.pi, n)
    qm = np.zeros(n)
    for step in range(steps):
        v = speed * (1.0 + 0.5 * np.sin(2 * np.pi * 0.3 * step * T + phase))
        qm = qm + v * T
        comp.cycle(qm, torque_scale * rng.standard_normal(n))
        yield step


def test_tracker_follows_its_recurrences(lexos):
    """Oracle in numpy (not the core): normalised RLS with forgetting, bounds and trace cap, replayed on the
    regressors and commands the core exposes; gates on |q̇_m| and |q̈_m| of the previous cycle."""
    comp = Compensator.from_device(lexos, underestimation=0.9, tracking={"acceleration_max": 1e6})
    t = comp.model.tracking
    n = comp.n
    gravity_map = np.array(comp.model.transmission.motor_from_joint_torque)
    theta = np.ones((n, 2))
    P = np.tile(0.5 * t.covariance_max * np.eye(2), (n, 1, 1))
    prev = None
    for _ in _motion(comp, 1500, np.random.default_rng(5)):
        d = comp.data
        tr = d.tracking
        if prev is not None:
            for i in range(n):
                if abs(prev["v"][i]) < t.velocity_min or abs(tr.acceleration[i]) > t.acceleration_max:
                    continue
                phi = np.array([prev["c"][i], prev["v_"][i]])
                y = prev["torque"][i] - prev["gravity"][i] - prev["load"][i]    # load-dependent losses held
                norm = np.abs(phi).sum()
                phi, y = phi / norm, y / norm
                k = P[i] @ phi / (t.forgetting + phi @ P[i] @ phi)
                theta[i] = np.clip(theta[i] + k * (y - phi @ theta[i]), t.scale_min, t.scale_max)
                P[i] = (P[i] - np.outer(k, phi @ P[i])) / t.forgetting
                if np.trace(P[i]) > t.covariance_max:
                    P[i] *= t.covariance_max / np.trace(P[i])
                P[i] = 0.5 * (P[i] + P[i].T)
        np.testing.assert_allclose(tr.scale_constant, theta[:, 0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(tr.scale_viscous, theta[:, 1], rtol=1e-9, atol=1e-12)
        prev = {"v": np.array(d.qd_motor), "c": np.array(tr.friction_constant), "v_": np.array(tr.friction_viscous),
                "torque": np.array(d.torque_motor), "gravity": gravity_map @ np.array(d.gravity_torque),
                "load": np.array(tr.friction_load)}
    assert np.array(tr.updates).min() > 1000
    assert np.abs(theta - 1).max() > 0.05          # the random torques moved the scales: something was tested


def test_tracked_split_scales_tau0_and_nu_and_holds_the_load_dependent_losses(lexos):
    """The split of the model's friction (issue 23: C_m0 and ν tracked): C_c from τ_0 alone (ν = β = 0, η_d = 1),
    C_v from ν, C_l = the load-dependent rest (β, η_d) held at the model — recomputed here from the device's
    arrays with the transmission's feedforward; the command is lossless + k w (C_l + σ_c C_c + σ_v C_v)."""
    from tendyn.transmission import Transmission

    comp = Compensator.from_device(lexos, underestimation=0.8, tracking={"acceleration_max": 1e6})
    for _ in _motion(comp, 400, np.random.default_rng(2), torque_scale=1.0):
        pass
    d, tr = comp.data, comp.data.tracking
    a = lexos.transmission.to_dict()

    def feedforward(**change):
        args = dict(tau0=a["tau0"], nu=a["nu"], beta=a["beta"], **{k: a[k] for k in a if k.startswith("bearing_")})
        eta = change.pop("reducer_efficiency", a["reducer_efficiency"])
        args.update(change)
        t = Transmission.from_arrays(a["motor_radius"], a["K"], a["reducer_ratio"], eta, a["pretension"], **args)
        return np.array(t.feedforward(np.array(d.torque_joint), np.array(d.qd)).torque_motor)

    lossless = np.array(d.torque_motor_lossless)
    zero = np.zeros_like(a["nu"])
    tau0_only = feedforward(nu=zero, beta=zero, reducer_efficiency=np.ones_like(a["reducer_efficiency"]))
    no_nu = feedforward(nu=zero)
    np.testing.assert_allclose(tr.friction_constant, tau0_only - lossless, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(tr.friction_load, no_nu - tau0_only, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(tr.friction_viscous, feedforward() - no_nu, rtol=1e-9, atol=1e-12)
    assert np.abs(tr.friction_load).max() > 0.1 * np.abs(tr.friction_constant).max()   # β, η_d matter here
    w = np.array(d.friction_weight)
    want = lossless + 0.8 * w * (np.array(tr.friction_load) + np.array(tr.scale_constant) * tr.friction_constant
                                 + np.array(tr.scale_viscous) * tr.friction_viscous)
    np.testing.assert_allclose(d.torque_motor, want, rtol=1e-9, atol=1e-12)
    assert np.abs(np.array(tr.scale_constant) - 1).max() > 1e-3       # the scales moved: the sum was tested


def test_tracker_learns_nothing_at_rest_or_when_gated_and_stays_in_its_bounds(lexos):
    """Near rest (below velocity_min) and with tracking_active off there is no update; under a command that
    keeps pushing the estimate up, the scales stop at scale_max."""
    comp = Compensator.from_device(lexos, tracking={"scale_max": 1.1, "acceleration_max": 1e6})
    for _ in _motion(comp, 500, np.random.default_rng(1), speed=0.5):
        pass
    assert np.array(comp.data.tracking.updates).max() == 0
    comp.reset()
    comp.data.tracking_active = False
    for _ in _motion(comp, 500, np.random.default_rng(1)):
        pass
    assert np.array(comp.data.tracking.updates).max() == 0
    comp.data.tracking_active = True
    for _ in _motion(comp, 3000, np.random.default_rng(1), torque_scale=5.0):
        pass
    s = np.concatenate([comp.data.tracking.scale_constant, comp.data.tracking.scale_viscous])
    assert s.max() <= 1.1 + 1e-12 and s.min() >= 0.2 - 1e-12


@pytest.fixture(scope="module")
def drift_run(lexos):
    """The self-test on the twin for 240 s with its τ_0 and ν drifting 1 + 0.3 sin(2π t / 600 s)."""
    return self_test_run(lexos, duration=240.0, drift=FrictionDrift(amplitude=0.3, period=600.0))


def test_C46_tracked_friction_follows_a_30_percent_drift(lexos, drift_run):
    """Issue 23: after 30 s the friction the tracked scales give a motor at 10 rad/s (no-load line c + b v of the
    model, where β and η_d add nothing: the twin's no-load friction there scales with the drift exactly) stays
    within 5 % of the twin's drifted friction at every sample on every transmission (measured 2.6 / 2.2 / 3.9 /
    3.2 %), 2.5 % RMS; the fixed model is off by up to 29 % over the same run. Was 7.7 / 7.6 % on transmissions
    2 and 3: σ_c scaled the load-dependent losses (β, η_d) that do not drift with τ_0, the self-test ran motor 3
    at 2.7–5.8 rad/s only, and the 10 s memory lagged the drift (friction_tracking.hpp, tracking.py)."""
    r = drift_run
    c, b = dissipation_bound(lexos, margin=1.0)
    keep = r.time >= 30.0
    tracked = (r.scale_constant * c + r.scale_viscous * b * 10.0) / (c + b * 10.0)
    err = tracked[keep] / r.truth[keep, None] - 1.0
    print("max", np.abs(err).max(axis=0), "rms", np.sqrt(np.mean(err ** 2, axis=0)))
    assert np.abs(err).max() < 0.05
    assert np.sqrt(np.mean(err ** 2, axis=0)).max() < 0.025
    assert np.abs(1.0 / r.truth[keep] - 1.0).max() > 0.2     # what the fixed model would be off by


def test_C46_tracked_compensation_keeps_the_reduction_of_the_model_before_the_drift(lexos):
    """Fig. 7 (k = 0.9): with the twin's friction 30 % up, the fixed identified model loses ~10 points of
    joint-1 reduction; after a 60 s self-test the tracked compensator is back within 1.5 points of the
    reduction the model had before the drift (the tracker is gated off while the hand moves the arm)."""
    before = 1 - hand_run(lexos, 0.9).rms_joint1 / hand_run(lexos, 0.0).rms_joint1
    g = hand_run(lexos, 0.0, twin_friction_scale=1.3)
    fixed = 1 - hand_run(lexos, 0.9, twin_friction_scale=1.3).rms_joint1 / g.rms_joint1
    comp = Compensator.from_device(lexos, underestimation=0.9, tracking=True)
    self_test_run(lexos, duration=60.0, drift=FrictionDrift(amplitude=0.3, period=1e9, phase=np.pi / 2),
                  compensator=comp)
    tracked = 1 - hand_run(lexos, 0.9, twin_friction_scale=1.3, compensator=comp).rms_joint1 / g.rms_joint1
    print(before, fixed, tracked)
    assert before - fixed > 0.05
    assert abs(tracked - before) < 0.015


def test_tracking_section_round_trips_and_older_files_still_load(lexos, tmp_path):
    on = Compensator.from_device(lexos, tracking={"forgetting": 0.9995, "velocity_min": 3.0})
    assert "section tracking 1" in on.text()
    assert "section tracking" not in Compensator.from_device(lexos).text()
    on.export(tmp_path / "t.comp")
    back = Compensator.load(tmp_path / "t.comp").model.tracking
    assert back.enabled and back.forgetting == 0.9995 and back.velocity_min == 3.0
    bad = on.text().replace("forgetting 0.9995", "forgetting 0.5")
    (tmp_path / "bad.comp").write_text(bad)
    with pytest.raises(ValueError, match="tracking.forgetting"):
        Compensator.load(tmp_path / "bad.comp")
    with pytest.raises(TypeError, match="unknown setting"):
        Compensator.from_device(lexos, tracking={"speed": 1.0})
