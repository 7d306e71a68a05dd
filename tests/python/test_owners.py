"""Issue 33: one owner per physical concept, each checked against an independent route."""

import numpy as np
import pytest

from tendyn.devices import bundled, generate
from tendyn.device import load_device
from tendyn.transmission import Transmission


def _friction_document(dev, path):
    """A FRICTION.json of made-up per-transmission friction for ``dev`` (τ0 = 0.02 + 0.01 i N m, ν = 1e-3 (i + 1)
    N m s/rad), written at ``path``; returns (the document, the path)."""
    import json

    n = dev.n_transmissions
    c0, nu = [0.02 + 0.01 * i for i in range(n)], [1e-3 * (i + 1) for i in range(n)]
    doc = {"format": "tendyn.friction/1", "device": dev.name, "n_transmissions": n, "coulomb_motor": c0,
           "viscous_motor": nu, "fits": [{"transmission": i + 1, "coulomb_motor": c0[i], "viscous_motor": nu[i],
                                          "coulomb_motor_std": 1e-4, "viscous_motor_std": 1e-5} for i in range(n)]}
    path.write_text(json.dumps(doc))
    return doc, path


@pytest.mark.parametrize("name", ["lexos", "generated"])
def test_motor_alone_speeds_hold_the_other_motors(name, tmp_path):
    """``Transmission.motor_alone_joint_speeds`` (the passivity bound's and the export summary's one definition):
    the motor velocities R_m⁻¹ K q̇ are v on motor i and 0 on every other (S0 eqs. 1–2), checked from the
    device's routing arrays, not the core's inverse."""
    if name == "generated":
        dev = load_device(generate.write_cable_device(tmp_path, 4, seed=3, differential=True))
    else:
        dev = load_device(bundled(name))
    arr = dev.routing_arrays()
    tr = Transmission.from_device(dev)
    for i in range(tr.n):
        qd = tr.motor_alone_joint_speeds(i, 2.5)
        qm = np.linalg.solve(np.diag(arr["motor_radius"]), arr["K"] @ qd)
        np.testing.assert_allclose(qm, 2.5 * np.eye(tr.n)[i], atol=1e-12)
    with pytest.raises(ValueError, match="motor index"):
        tr.motor_alone_joint_speeds(tr.n, 1.0)


def test_the_velocity_threshold_rule_is_the_treatments():
    """One rule (``tendyn.ident.treatment``) for IDIM in memory, ``--stream`` and the S2 design's cond(W): the
    default is DEFAULT_VELOCITY_FRACTION of each joint's peak, a number the same for all, a tuple per joint;
    a sample at exactly the threshold is kept."""
    from tendyn.ident.treatment import DEFAULT_VELOCITY_FRACTION, above_threshold, velocity_thresholds

    peaks = np.array([2.0, 8.0, 0.5])
    np.testing.assert_array_equal(velocity_thresholds(None, peaks), DEFAULT_VELOCITY_FRACTION * peaks)
    np.testing.assert_array_equal(velocity_thresholds(0.15, peaks), [0.15] * 3)
    np.testing.assert_array_equal(velocity_thresholds((0.1, 0.2, 0.3), peaks), [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(above_threshold([-0.2, 0.1, 0.15, -0.15], 0.15), [True, False, True, True])


def test_friction_json_is_read_once_by_a_compensator_with_its_passivity_controller(tmp_path, monkeypatch):
    """The compensator and its passivity bound take one loss model, built once from FRICTION.json (with the
    shares given): the file is read once and the bound is the one of those losses."""
    from tendyn.control import Compensator
    from tendyn.control.passivity import dissipation_bound
    from tendyn.ident import loss_model

    dev = load_device(bundled("lexos"))
    doc, path = _friction_document(dev, tmp_path / "friction.json")
    reads = []
    real = loss_model._read
    monkeypatch.setattr(loss_model, "_read", lambda f: reads.append(f) or real(f))
    comp = Compensator.from_device(dev, friction=str(path), passivity=True)
    assert len(reads) == 1
    c, b = dissipation_bound(dev, loss_model.identified_losses(dev, doc))
    np.testing.assert_allclose(np.array(comp.model.passivity.dissipation_coulomb), c, rtol=1e-12)


def test_a_calibrated_device_records_the_source_of_every_term(tmp_path):
    """``calibrate``: identified friction replaces every loss term of the file (one loss model) with its document
    named, an identified capstan stiffness replaces the file's per drive, and the compensator built from the
    calibrated device is the one built from the same friction directly."""
    from tendyn.control import Compensator
    from tendyn.devices.generate import write_parallelogram_arm
    from tendyn.ident.calibrated import CalibrationError, calibrate

    dev = load_device(bundled("lexos"))
    doc, path = _friction_document(dev, tmp_path / "FRICTION.json")
    plain = calibrate(dev)
    assert set(plain.sources.values()) == {"file"} and plain.losses is None
    cal = calibrate(dev, str(path))
    assert cal.sources["tau0"] == cal.sources["nu"] == "identified: FRICTION.json"
    assert cal.sources["bearings"] == "none"          # replaced, not stacked on the file's
    a = Compensator.from_device(cal).model.transmission
    b = Compensator.from_device(dev, friction=str(path)).model.transmission
    np.testing.assert_array_equal(np.array(a.tau0), np.array(b.tau0))
    with pytest.raises(CalibrationError, match="about 'other'"):
        calibrate(dev, {**doc, "device": "other"})

    arm = load_device(write_parallelogram_arm(tmp_path, seed=1))
    k = [d.stiffness_motor * 2 for d in arm.drives]
    stiff = calibrate(arm, stiffness=k)
    assert [d.stiffness_motor for d in stiff.device.drives] == k
    assert stiff.sources["stiffness_motor[1]"] == "identified: stiffness"
    assert [d.stiffness_motor for d in arm.drives] == [v / 2 for v in k]        # the file's device untouched
    with pytest.raises(CalibrationError, match="stiffness_motor"):
        calibrate(arm, stiffness=k[:-1])


def test_the_passivity_bound_of_a_calibrated_device_is_the_one_of_its_friction():
    """``passivity_model`` / ``dissipation_bound`` take the calibrated device and its one loss model."""
    from tendyn.control.passivity import dissipation_bound
    from tendyn.ident.calibrated import calibrate

    dev = load_device(bundled("lexos"))
    n = dev.n_transmissions
    doc = {"device": dev.name, "tau0": (np.eye(n) * 0.5).tolist(), "nu": (np.eye(n) * 2.0).tolist()}
    c_cal, b_cal = dissipation_bound(calibrate(dev, doc))
    c_doc, b_doc = dissipation_bound(dev, doc)
    c_file, _ = dissipation_bound(calibrate(dev))
    np.testing.assert_allclose(c_cal, c_doc, rtol=1e-12)
    np.testing.assert_allclose(b_cal, b_doc, rtol=1e-12)
    np.testing.assert_allclose(c_file, dissipation_bound(dev)[0], rtol=1e-12)
    assert not np.allclose(c_cal, c_file)


def test_elastic_drives_is_the_devices(tmp_path):
    """Whether a device's capstan drives are elastic has one owner, ``SerialDevice.elastic_drives``: identification's
    model (velocity threshold, drive-stretch refit) and the twin's default exciting design read it. Independent
    route: the file's ``[[drives]]`` and their ``stiffness_motor``, read from the TOML text."""
    import tomllib

    from tendyn.device import compile_device
    from tendyn.ident.model import cached_model
    from tendyn.sim.experiments import default_design

    arm = generate.write_parallelogram_arm(tmp_path, seed=0)
    for path in (arm, bundled("cea_branch"), bundled("lexos")):
        raw = tomllib.loads(open(path).read())
        truth = bool(raw.get("drives")) and all(d["stiffness_motor"] > 0 for d in raw["drives"])
        dev = load_device(path)
        assert dev.elastic_drives is truth
        assert cached_model(compile_device(dev)).elastic_drives is truth
        assert (default_design(dev) == "fast") is truth
