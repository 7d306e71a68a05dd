"""Coupled actuators, one space at a time (issue 29, item 5).

A tendon-coupled instrument wrist generated here (4 motors, a dense non-symmetric 4×4 coupling G,
``tendyn.devices.generate.coupled_wrist_toml``) follows sums of sines; its log is written from a truth this test
builds independently of the estimator: joint torques by Pinocchio's RNEA plus joint-side friction, motor-side
rotor inertia and friction on the motor angles q_m = G q, motor torques y = G⁻ᵀ τ_J + y_motor-side. The model
of the fit contains that truth exactly, so on the fitted log a relative residual near or above 1 (worse than
predicting zero) is impossible in either space; identify (joint space, τ = Gᵀ y, and motor space), validate
and ``IdentifiedModel.predict`` must agree, each naming its space.

Plants tried (each makes a test below fail; two are kept as tests that must see the failure):
the coupling's transpose used where its inverse belongs for the joint angles (q = G⁻ᵀ q_m instead of G⁻¹ q_m)
→ residuals ~0.3–1; the motor torques of the prediction by G⁻¹ instead of G⁻ᵀ → motor errors ~1.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.device import load_device
from tendyn.devices.generate import coupled_wrist_toml
from tendyn.ident import IDIM, IdentModel
from tendyn.io import make_log

RATE = 500.0
FV, FS = 2e-3, 1.5e-3            # joint side [N·m·s/rad], [N·m], the test's truth
JM, FVM, FSM = 3e-7, 2e-5, 3e-4  # motor side [kg·m²], [N·m·s/rad], [N·m]


@pytest.fixture(scope="module")
def wrist(tmp_path_factory):
    path = tmp_path_factory.mktemp("dev") / "wrist4c0.toml"
    path.write_text(coupled_wrist_toml(4, seed=0), encoding="utf-8")
    m = IdentModel(load_device(path))
    m.file = path
    return m


def _log(m, seed=0, duration=8.0):
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * RATE)) / RATE
    n = m.n_active
    q = np.zeros((t.size, n)); qd = np.zeros_like(q); qdd = np.zeros_like(q)
    for j in range(n):
        for k in range(1, 4):
            a, f, ph = rng.uniform(0.2, 0.45) / k, 0.3 * k * (1 + 0.3 * j), rng.uniform(0, 2 * np.pi)
            w = 2 * np.pi * f
            q[:, j] += a * np.sin(w * t + ph); qd[:, j] += a * w * np.cos(w * t + ph)
            qdd[:, j] -= a * w * w * np.sin(w * t + ph)
    model = m.compiled.pinocchio_model
    data = model.createData()
    tau = np.array([pin.rnea(model, data, q[s], qd[s], qdd[s]) for s in range(t.size)])
    tau += FV * qd + FS * np.tanh(qd / 1e-3)
    G = m.device.motor_joint_matrix()              # from the file, not through the estimator's model
    qm, qdm, qddm = q @ G.T, qd @ G.T, qdd @ G.T
    y = np.linalg.solve(G.T, tau.T).T + JM * qddm + FVM * qdm + FSM * np.tanh(qdm / 1e-3)
    cols = {"time": t, **{f"q_motor_{i + 1}": qm[:, i] for i in range(n)},
            **{f"torque_motor_{i + 1}": y[:, i] for i in range(n)}}
    return make_log(cols, device=m.device.name, rate_hz=RATE, seed=seed, experiment="exciting")


@pytest.fixture(scope="module")
def fitted(wrist):
    log = _log(wrist)
    est = IDIM(wrist.device, cutoff_hz=10.0, decimate=10).fit(log, crossval=False)
    return log, est


def test_coupling_is_dense(wrist):
    G = wrist.G
    off = G - np.diag(np.diag(G))
    assert np.count_nonzero(np.abs(off) > 1e-9) >= 10 and not np.allclose(G, G.T)


def test_identify_residuals_small_in_both_spaces(fitted):
    _, est = fitted
    r = est.result_
    assert r.coupled and len(r.per_motor_residual_rel) == 4
    assert max(r.per_joint_residual_rel) < 0.01, r.per_joint_residual_rel
    assert max(r.per_motor_residual_rel) < 0.01, r.per_motor_residual_rel
    d = r.to_dict()
    assert d["residual_space"] == "joint" and d["per_motor_residual_rel"] == r.per_motor_residual_rel
    text = r.table()
    assert "joint space" in text and "motor space" in text


def test_predict_agrees_with_identify(fitted):
    log, est = fitted
    p = est.predict(log)
    ej, em = p.relative_error, p.relative_error_motor
    assert max(ej) < 0.01 and max(em) < 0.01, (ej, em)
    # the same log, the same model, the same space: the errors agree with identify's residuals to noise level
    assert np.all(np.abs(ej - est.result_.per_joint_residual_rel) < 0.005)
    assert np.all(np.abs(em - est.result_.per_motor_residual_rel) < 0.005)
    d = p.to_dict()
    assert d["space"] == "joint" and len(d["relative_error_motor"]) == 4 and d["edge_samples"] > 0
    assert "(joint space)" in p.table() and "(motor space)" in p.table()
    # the motor torques of the prediction produce its joint torques: τ = Gᵀ y
    np.testing.assert_allclose(p.motor @ est.model_.G, p.joint, atol=1e-9)


def test_validate_command_names_spaces(fitted, wrist, tmp_path, capsys):
    from tendyn.cli import main
    from tendyn.io import write_log

    log, _ = fitted
    lp = write_log(log, tmp_path / "log.parquet")
    params = tmp_path / "p.json"
    assert main(["identify", str(wrist.file), str(lp), "--out", str(params), "--quiet", "--cutoff-hz", "10",
                 "--decimate", "10"]) == 0
    out = capsys.readouterr().out
    assert "per motor (motor space" in out and "per joint (joint space" in out
    assert main(["validate", str(wrist.file), str(params), str(lp), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["logs"][0]["space"] == "joint"
    assert max(doc["logs"][0]["relative_error"]) < 0.01 and max(doc["logs"][0]["relative_error_motor"]) < 0.01


def test_transposed_coupling_is_seen(wrist, monkeypatch):
    """Plant: the joint angles through the coupling's inverse transpose (q = G⁻ᵀ q_m) where its inverse belongs."""
    log = _log(wrist, seed=1)
    orig = IdentModel.joint_signals

    def planted(self, lg):
        t, q, tau = orig(self, lg)
        qm = (q - self.joint_offsets) @ self.G.T
        return t, np.linalg.solve(self.G.T, qm.T).T + self.joint_offsets, tau

    monkeypatch.setattr(IdentModel, "joint_signals", planted)
    est = IDIM(wrist.device, cutoff_hz=10.0, decimate=10).fit(log, crossval=False)
    assert max(est.result_.per_joint_residual_rel) > 0.1


def test_motor_map_plant_is_seen(fitted, monkeypatch):
    """Plant: the predicted motor torques by G⁻¹ τ (a transpose lost) instead of G⁻ᵀ τ."""
    log, est = fitted
    monkeypatch.setattr(IdentModel, "motor_torques", lambda self, tau: np.linalg.solve(self.G, np.asarray(tau).T).T)
    assert max(est.predict(log).relative_error_motor) > 0.1
