"""Identified friction into the compensator, one loss model at a time (issue 17, items 3–5; C7, C9, C10, C46).

How it could go wrong, and what each test catches: the compensator adding the device file's bearings, β and η_d
on top of identified friction that already holds them (it then over-compensates, 2.4× on a lab's device, and a
haptic device turns active) — the compensated friction must equal the identified law; a model file that mixes
identified and device terms — the core refuses it; a friction file of another device, count or sign — one line,
exit 2; the load term lost between identification and compensation — compensation at two loads."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tendyn.devices.generate import write_cable_device
from tendyn import _core
from tendyn.cli import main
from tendyn.control import Compensator
from tendyn.device import load_device
from tendyn.ident.friction import isolated_move_joint_speeds
from tendyn.ident.loss_model import LossModelError, identified_losses

SPEEDS = (0.5, 2.0, 5.0, 10.0)


@pytest.fixture(scope="module")
def lossy(tmp_path_factory):
    """A generated 3-transmission device with bearings, β and reducers on every cable."""
    return load_device(write_cable_device(tmp_path_factory.mktemp("dev"), 3, bearings=True, seed=4))


def friction_doc(device, c0, nu, load=None):
    """A FRICTION.json document written by hand (the format of docs/friction-file.md)."""
    n = device.n_transmissions
    fits = [{"transmission": i + 1, "coulomb_motor": c0[i], "viscous_motor": nu[i], "coulomb_motor_std": 1e-4,
             "viscous_motor_std": 1e-5, **({} if load is None else {"load_coefficient": load[i]})} for i in range(n)]
    doc = {"format": "tendyn.friction/1", "device": device.name, "n_transmissions": n,
           "coulomb_motor": list(c0), "viscous_motor": list(nu), "fits": fits}
    if load is not None:
        doc["load_coefficient"] = list(load)
    return doc


def compensated_friction(comp: Compensator, device, j: int, v: float, load: float) -> float:
    """Friction part the compensator's statics put at motor j (0-based) moving alone at motor speed v [rad/s]
    against a lossless load torque ``load`` [N·m] at that motor: C_m − C_0 from the core feedforward."""
    arr = device.routing_arrays()
    tr = comp.model.transmission
    qd = isolated_move_joint_speeds(arr["K"], arr["motor_radius"], j, "S2", v)
    Gt = np.linalg.inv(np.diag(arr["motor_radius"])) @ arr["K"]      # τ_J = Gᵀ C_m (virtual work)
    tau = Gt.T[:, j] * load
    d = _core.TransmissionData(tr)
    _core.motor_torque_feedforward(tr, d, tau, qd)
    return float(np.array(d.torque_motor)[j] - load)


def test_compensated_friction_equals_identified_friction(lossy):
    """Item 3: on a device with bearings, β and reducers, a compensator built from identified friction puts at
    each motor exactly the identified law C_m0 + c_L |C_0| + ν|v| (within 2 %, here 1e-9) at several speeds,
    both directions and two loads — the oracle is the law itself, not the core."""
    n = lossy.n_transmissions
    c0, nu, cl = [0.02, 0.035, 0.05][:n], [1e-3, 2e-3, 1.5e-3][:n], [0.1, 0.15, 0.2][:n]
    comp = Compensator.from_device(lossy, friction=friction_doc(lossy, c0, nu, cl))
    assert comp.loss_sources == {"tau0": "identified", "nu": "identified", "beta": "none", "bearings": "none",
                                 "reducer_efficiency": "identified"}
    for j in range(n):
        for v in SPEEDS:
            for s in (1.0, -1.0):
                for load in (0.0, 0.3, -0.2):
                    want = s * (c0[j] + cl[j] * abs(load) + nu[j] * v)
                    got = compensated_friction(comp, lossy, j, s * v, load)
                    assert got == pytest.approx(want, rel=0.02, abs=1e-12), (j, v, s, load)
                    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_device_losses_would_stack_on_identified_friction(lossy):
    """The failure item 3 prevents, shown: the device file's own losses (bearings, β, η_d) alone already give
    friction of the size identified; adding them to the identified τ0 (the old behaviour) doubles it."""
    n = lossy.n_transmissions
    own = Compensator.from_device(lossy)
    c_dev = [compensated_friction(own, lossy, j, 5.0, 0.3) for j in range(n)]
    ident = Compensator.from_device(lossy, friction=friction_doc(lossy, [0.02] * n, [1e-3] * n))
    c_id = [compensated_friction(ident, lossy, j, 5.0, 0.3) for j in range(n)]
    assert all(c > 0.01 for c in c_dev)
    # the identified model does not carry a trace of the device's β, bearings or η_d
    t = ident.model.transmission
    assert np.all(np.array(t.beta) == 0) and np.all(np.array(t.bearing_count) == 0)
    assert np.all(np.array(t.reducer_efficiency) == 1.0)
    assert c_id == pytest.approx([0.02 + 5e-3] * n, rel=1e-9)


def test_core_refuses_a_model_that_mixes_identified_and_device_losses(lossy, tmp_path):
    """The core's check (compensator.hpp loss_sources_issue): identified τ0 with the device's bearings is refused,
    and so is a term recorded as none that carries a loss; the model file keeps the sources."""
    comp = Compensator.from_device(lossy, friction=friction_doc(lossy, [0.02] * 3, [1e-3] * 3, [0.1] * 3))
    path = tmp_path / "x.comp"
    comp.export(path)
    back = Compensator.load(path)
    assert back.loss_sources == comp.loss_sources
    text = path.read_text()
    assert "section losses 1" in text and "bearings none" in text
    m = _core.CompensatorModel()
    m.transmission, m.chain, m.device = Compensator.from_device(lossy).model.transmission, comp.model.chain, "x"
    m.loss_source = ["identified", "identified", "device", "device", "device"]
    assert "one loss model at a time" in m.first_issue()
    m.loss_source = ["device", "device", "none", "device", "device"]      # β recorded none, but the file has β
    assert "beta is recorded as none" in m.first_issue()
    mixed = text.replace("bearings none", "bearings device")
    (tmp_path / "mixed.comp").write_text(mixed)
    with pytest.raises(ValueError, match="one loss model at a time"):
        Compensator.load(tmp_path / "mixed.comp")


@pytest.mark.parametrize("change, needle", [
    (lambda d: d.update(device="L-EXOS"), "device: the friction is about 'L-EXOS'"),
    (lambda d: d.update(n_transmissions=2), "n_transmissions"),
    (lambda d: (d["coulomb_motor"].__setitem__(1, -0.01), d["fits"][1].__setitem__("coulomb_motor", -0.01)),
     "coulomb_motor[2]: must be finite and >= 0"),
    (lambda d: (d["load_coefficient"].__setitem__(0, 1.5), d["fits"][0].__setitem__("load_coefficient", 1.5)),
     "load_coefficient[1]: must be in [0, 1)"),
])
def test_export_refuses_a_bad_friction_file_with_one_line(lossy, tmp_path, capsys, change, needle):
    """Item 5: another device, another count, a negative value: exit 2, one line naming the field."""
    doc = friction_doc(lossy, [0.02] * 3, [1e-3] * 3, [0.1] * 3)
    change(doc)
    f = tmp_path / "friction.json"
    f.write_text(json.dumps(doc))
    out = tmp_path / "x.comp"
    assert main(["export", "compensator", str(lossy.path), "--friction", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not out.exists()


def test_from_device_takes_the_documented_inputs(lossy, tmp_path):
    """``Compensator.from_device(dev, friction=PATH)`` takes FRICTION.json and ``decompose --json`` output alike
    (the same per-branch losses), as its docstring says."""
    doc = friction_doc(lossy, [0.02, 0.03, 0.04], [1e-3, 2e-3, 3e-3], [0.1, 0.0, 0.2])
    f = tmp_path / "friction.json"
    f.write_text(json.dumps(doc))
    a = Compensator.from_device(lossy, friction=f)
    dec = tmp_path / "dec.json"
    r = subprocess.run([sys.executable, "-m", "tendyn.cli", "decompose", str(lossy.path), str(f), "--json"],
                       capture_output=True, text=True, check=True)
    dec.write_text(r.stdout)
    b = Compensator.from_device(lossy, friction=dec)
    for key in ("tau0", "nu", "reducer_efficiency"):
        np.testing.assert_allclose(np.array(getattr(a.model.transmission, key)),
                                   np.array(getattr(b.model.transmission, key)), rtol=1e-12)
    assert a.model.friction_source == "friction.json"
    with pytest.raises(LossModelError, match="unknown friction format"):
        identified_losses(lossy, {"format": "something/1"})


def test_a_built_loss_model_is_taken_as_it_is_and_only_for_its_device(lossy, tmp_path):
    """An :class:`IdentifiedLosses` passed as ``friction`` is used as built (``tendyn export`` builds it once, for
    the summary and the compensator): the compensator equals the one built from the file; a loss model of
    another device is refused, not applied to a routing it was not identified on."""
    f = tmp_path / "friction.json"
    f.write_text(json.dumps(friction_doc(lossy, [0.02, 0.03, 0.04], [1e-3, 2e-3, 3e-3])))
    built = identified_losses(lossy, f)
    assert identified_losses(lossy, built) is built
    a, b = Compensator.from_device(lossy, friction=f), Compensator.from_device(lossy, friction=built)
    for key in ("tau0", "nu", "reducer_efficiency"):
        np.testing.assert_array_equal(np.array(getattr(a.model.transmission, key)),
                                      np.array(getattr(b.model.transmission, key)))
    assert b.model.friction_source == a.model.friction_source
    other = load_device(write_cable_device(tmp_path, 3, bearings=True, seed=5, name="other"))
    with pytest.raises(LossModelError, match="not 'other'"):
        identified_losses(other, built)
