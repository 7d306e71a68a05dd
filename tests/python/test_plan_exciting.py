"""`tendyn plan exciting` (issue 18 item 7): an optimised Fourier trajectory inside the joint, speed and torque
limits, cond(W) reported and lowered, exported as references that the twin runs; identification on the twin's
log recovers the parameters of a small generated rigid-body device."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.device import load_device
from tendyn.devices.generate import write_cable_device
from tendyn.ident import IDIM, IdentModel
from tendyn.ident.exciting import FourierDesign, plan_exciting


def test_plan_simulate_identify_recovers_the_parameters(tmp_path, capsys):
    """plan (CLI) → the CSV's design runs on the twin (no friction: a rigid-body truth) → identify: every base
    parameter within 4σ of the truth (the device file's links and rotors, no friction), the links' and rotors'
    with %σ below 10 %; the optimised cond(W) is below the starting one; the references stay inside the limits
    it reports."""
    from tendyn.cli import main
    from tendyn.io import read_log
    from tendyn.sim.experiments import exciting_trajectory

    path = write_cable_device(tmp_path, 2, seed=5)
    ref = tmp_path / "ref.csv"
    assert main(["plan", "exciting", str(path), "--out", str(ref), "--json", "--iterations", "150"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cond_scaled"] < doc["cond_scaled_initial"] and doc["cond"] > 0
    log = read_log(ref)
    q = log.stack("q_ref_")
    lim = doc["limits"]
    assert np.all(q >= np.array(lim["lower"]) - 1e-9) and np.all(q <= np.array(lim["upper"]) + 1e-9)
    assert np.all(np.abs(log.stack("qd_ref_")) <= np.array(lim["max_speed"]) + 1e-9)
    design = FourierDesign.from_dict(log.meta["options"]["design"])
    dev = load_device(path)
    run = exciting_trajectory(dev, duration=2 * design.period, design=design, friction=False, seed=1)
    fit = IDIM(dev, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(run.log, crossval=False)
    m = IdentModel(dev)
    truth = m.prior()
    for k, n in enumerate(m.standard_names):          # the twin without friction: no FV, FS, OFFSET
        if n.rstrip("0123456789") in ("FV", "FS", "OFFSET", "FVm", "FSm"):
            truth[k] = 0.0
    xb = m.base.combination @ truth
    z = np.abs(fit.params_ - xb) / fit.stderr_
    assert np.all(z < 4.0), dict(zip(fit.names_, z))
    inertial = np.abs(xb) > 0                          # the links' and rotors' base parameters, determined
    assert inertial.sum() >= 5 and np.all(fit.rel_stderr_[inertial] < 10.0)


def test_optimisation_lowers_cond_and_keeps_the_torque_limit(tmp_path):
    """A tight motor peak torque is respected (the torques of the file's model), and more iterations give a
    cond(W) no worse."""
    path = write_cable_device(tmp_path, 3, seed=2)
    path.write_text(path.read_text().replace("peak_torque = 3.0", "peak_torque = 0.35")
                    .replace("continuous_torque = 1.0", "continuous_torque = 0.3"))
    dev = load_device(path)
    a = plan_exciting(dev, iterations=0, seed=1)
    b = plan_exciting(dev, iterations=120, seed=1)
    assert b.cond_scaled <= a.cond_scaled
    peak = np.array(b.limits["peak_motor_torque"])
    assert np.all(peak == 0.35)
    assert np.all(np.array(b.peaks["motor_torque"]) <= peak + 1e-9)
    assert b.peaks["motor_torque"][0] > 0.9 * 0.35         # the torque limit is what bounds it
    path.write_text(path.read_text().replace("peak_torque = 0.35", "peak_torque = 0.1").replace(
        "continuous_torque = 0.3", "continuous_torque = 0.05"))
    with pytest.raises(ValueError, match="motor 1 needs .* to hold the centre"):
        plan_exciting(load_device(path), iterations=0)
    q, qd, qdd = b.design.at(np.array([0.0]))
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-9)
