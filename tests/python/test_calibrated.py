"""Issue 33 item 1: one calibrated device. Every consumer of identified values (maps, zwidth, validate, export
compensator|transmission, decompose, the S0 pipeline) reads them through the :class:`CalibratedDevice` that
``commands.shared.calibrated`` / ``ident.calibrated.calibrate`` builds, each document is read once, and each value's
source is recorded.

How the "through the calibrated device" tests can fail: ``calibrate`` is wrapped so that the device it returns
carries the document's identified values scaled by 2 (:func:`_through_calibrated`); a consumer that takes them from the calibrated device gives
what it gives for a document of doubled values, one that re-reads the file gives the file's own."""

import json
from pathlib import Path

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.device import load_device
from tendyn.devices import bundled, generate

SCALE = 2.0


def _friction(dev, path, scale=1.0):
    """A FRICTION.json of made-up friction (τ0 = 0.02 + 0.01 i N m, ν = 1e-3 (i + 1) N m s/rad, times ``scale``)."""
    n = dev.n_transmissions or len(dev.drives)
    c0 = [scale * (0.02 + 0.01 * i) for i in range(n)]
    nu = [scale * 1e-3 * (i + 1) for i in range(n)]
    doc = {"format": "tendyn.friction/1", "device": dev.name, "n_transmissions": n, "coulomb_motor": c0,
           "viscous_motor": nu, "fits": [{"transmission": i + 1, "coulomb_motor": c0[i], "viscous_motor": nu[i],
                                          "coulomb_motor_std": 1e-4, "viscous_motor_std": 1e-5} for i in range(n)]}
    path.write_text(json.dumps(doc))
    return path


def _scaled(doc):
    """The identified values of a FRICTION.json or PARAMS.json document times SCALE."""
    doc = json.loads(json.dumps(doc))
    if "coulomb_motor" in doc:
        doc["coulomb_motor"] = [SCALE * v for v in doc["coulomb_motor"]]
        doc["viscous_motor"] = [SCALE * v for v in doc["viscous_motor"]]
        for f in doc.get("fits", []):
            f["coulomb_motor"] *= SCALE
            f["viscous_motor"] *= SCALE
    if "params" in doc:
        doc["params"] = [dict(p, value=SCALE * p["value"]) for p in doc["params"]]
    return doc


@pytest.fixture
def reads(monkeypatch):
    """Counts of the reads of each file name (``Path.read_bytes`` / ``read_text`` and ``open``)."""
    import builtins

    counts = {}
    real_bytes, real_text, real_open = Path.read_bytes, Path.read_text, builtins.open

    def count(p):
        name = Path(p).name if isinstance(p, (str, Path)) else None
        if name:
            counts[name] = counts.get(name, 0) + 1

    def read_bytes(self):
        count(self)
        return real_bytes(self)

    def read_text(self, *a, **k):
        count(self)
        return real_text(self, *a, **k)

    def open_(file, *a, **k):
        count(file)
        return real_open(file, *a, **k)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    monkeypatch.setattr(Path, "read_text", read_text)
    monkeypatch.setattr(builtins, "open", open_)
    return counts


def _json(capsys, argv):
    capsys.readouterr()
    assert main(argv) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def _numbers(doc):
    """The numbers of a command's JSON document, in order (its texts: file names, sources, left out)."""
    if isinstance(doc, dict):
        return [x for _, v in sorted(doc.items()) for x in _numbers(v)]
    if isinstance(doc, list):
        return [x for v in doc for x in _numbers(v)]
    return [float(doc)] if isinstance(doc, (int, float)) and not isinstance(doc, bool) else []


def _through_calibrated(capsys, monkeypatch, tmp_path, argv_of, make_doc):
    """Run a command (``argv_of(path)``) on a document of identified values with ``calibrate`` doubling them in
    the calibrated device, and on the document with its values doubled on disk: the same numbers, unlike those
    of the document as it is."""
    plain = make_doc(tmp_path / "plain.json", 1.0)
    twice = make_doc(tmp_path / "twice.json", SCALE)
    as_file = _numbers(_json(capsys, argv_of(plain)))
    on_disk = _numbers(_json(capsys, argv_of(twice)))
    assert not np.allclose(as_file, on_disk)            # the identified values show in the output
    from tendyn.ident import calibrated as mod

    real = mod.calibrate
    with monkeypatch.context() as m:
        m.setattr(mod, "calibrate", lambda device, friction=None, params=None, *a, **k: real(
            device, _scaled(json.loads(Path(friction).read_text())) if friction is not None else None,
            _scaled(json.loads(Path(params).read_text())) if params is not None else None, *a, **k))
        through = _numbers(_json(capsys, argv_of(plain)))
    np.testing.assert_allclose(through, on_disk, rtol=1e-9, atol=1e-12)


LEXOS = load_device(bundled("lexos"))


@pytest.mark.parametrize("argv", [
    ["maps", "lexos", "--friction", "{f}", "--points", "2", "--json"],
    ["export", "compensator", "lexos", "--friction", "{f}", "--out", "{dir}/x.comp", "--json"],
    ["export", "transmission", "lexos", "--friction", "{f}", "--out", "{dir}/x.model", "--json"],
    ["decompose", "lexos", "{f}", "--json"],
    ["zwidth", "lexos", "--friction", "{f}", "--stiffness", "1000:1000:1", "--damping", "0:0:1", "--modes",
     "passivity", "--scheduler", "none", "--horizon", "0.05", "--quiet", "--json"],
], ids=["maps", "export-compensator", "export-transmission", "decompose", "zwidth"])
def test_friction_consumers_take_it_from_the_calibrated_device(argv, capsys, monkeypatch, tmp_path):
    def argv_of(path):
        return [a.format(f=path, dir=tmp_path) for a in argv]

    _through_calibrated(capsys, monkeypatch, tmp_path, argv_of, lambda p, s: _friction(LEXOS, p, s))


@pytest.mark.parametrize("argv", [
    ["maps", "lexos", "--friction", "{f}", "--points", "2", "--json"],
    ["export", "compensator", "lexos", "--friction", "{f}", "--out", "{dir}/x.comp", "--json"],
    ["decompose", "lexos", "{f}", "--json"],
    ["zwidth", "lexos", "--friction", "{f}", "--stiffness", "1000:1000:1", "--damping", "0:0:1", "--modes",
     "passivity", "--scheduler", "none", "--horizon", "0.05", "--quiet", "--json"],
], ids=["maps", "export-compensator", "decompose", "zwidth"])
def test_friction_json_is_read_once(argv, capsys, reads, tmp_path):
    path = _friction(LEXOS, tmp_path / "FRICTION.json")
    reads.clear()
    assert main([a.format(f=path, dir=tmp_path) for a in argv]) == 0, capsys.readouterr().err
    assert reads.get("FRICTION.json") == 1, reads


def _params_of(model, path, scale=1.0, **extra):
    """A PARAMS.json of made-up base parameters of an identification model (1 + 0.1 k in their units)."""
    names = model.base.names
    doc = {"format": "tendyn.params/1", "device": model.device.name,
           "params": [{"name": n, "value": scale * (1.0 + 0.1 * k), "stderr": 0.0,
                       "expression": model.base.expression(k, model.standard_names)} for k, n in enumerate(names)],
           **extra}
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """A generated 2-joint cable arm, its identification model and a short log of it."""
    from tendyn.ident import IdentModel
    from tendyn.io import make_log, write_log

    folder = tmp_path_factory.mktemp("arm")
    dev = load_device(generate.write_cable_device(folder, 2, seed=3))
    m = IdentModel(dev)
    t = np.arange(2000) / 1000.0
    q = np.stack([0.3 * np.sin(2 * np.pi * (0.5 + j) * t) for j in range(2)], 1)
    qm = (q - m.joint_offsets) @ m.G.T
    cols = {"time": t, **{f"q_motor_{i + 1}": qm[:, i] for i in range(2)},
            **{f"torque_motor_{i + 1}": np.sin(2 * np.pi * (0.7 + i) * t) for i in range(2)}}
    log = write_log(make_log(cols, device=dev.name, rate_hz=1000.0, seed=0, experiment="exciting"),
                    folder / "log.csv")
    return dev, m, log


def test_validate_takes_the_parameters_from_the_calibrated_device_read_once(arm, capsys, monkeypatch, tmp_path,
                                                                            reads):
    dev, m, log = arm

    def argv_of(path):
        return ["validate", str(dev.path), str(path), str(log), "--json"]

    _through_calibrated(capsys, monkeypatch, tmp_path, argv_of, lambda p, s: _params_of(m, p, s))
    path = _params_of(m, tmp_path / "PARAMS.json")
    reads.clear()
    assert main(argv_of(path)) == 0
    assert reads.get("PARAMS.json") == 1, reads


def test_maps_takes_capstan_parameters_and_stiffness_from_the_calibrated_device(capsys, monkeypatch, tmp_path,
                                                                                reads):
    """Capstan maps (cea_branch): PARAMS.json read once, through the calibrated device; the stiffness given is
    the calibrated device's, with its source recorded; a PARAMS.json of another version of the device file is
    refused in one line unless --force."""
    from tendyn.analysis.operational import true_params

    dev = load_device(bundled("cea_branch"))

    def make(path, scale):
        path.write_text(json.dumps({"device": dev.name, "params": [dict(p, value=p["value"] * scale)
                                                                   for p in true_params(dev)]}))
        return path

    def argv_of(path):
        return ["maps", "cea_branch", str(path), "--points", "3", "--half-width", "0.01", "--json"]

    _through_calibrated(capsys, monkeypatch, tmp_path, argv_of, make)
    path = make(tmp_path / "PARAMS.json", 1.0)
    other = json.loads(path.read_text())
    other["device_sha256"] = "0" * 64               # identified on another version of the file
    path.write_text(json.dumps(other))
    capsys.readouterr()
    assert main(argv_of(path)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another version" in err[0] and "--force" in err[0], err
    k = [2.0 * d.stiffness_motor for d in dev.drives]
    reads.clear()
    doc = _json(capsys, argv_of(path) + ["--force", "--stiffness", ",".join(map(str, k))])
    assert reads.get("PARAMS.json") == 1, reads
    assert doc["sources"]["stiffness_motor[1]"] == "identified: stiffness"
    assert doc["sources"]["params"] == "identified: PARAMS.json"
    np.testing.assert_allclose(doc["stiffness_motor_N_m_per_rad"], k)


def test_the_sources_are_recorded(tmp_path, capsys):
    """Each term's source: ``file`` without a document, ``identified: <document>`` with one (calibrate and the
    zwidth result)."""
    from tendyn.ident.calibrated import calibrate

    path = _friction(LEXOS, tmp_path / "FRICTION.json")
    plain, cal = calibrate(LEXOS), calibrate(LEXOS, path)
    assert plain.friction_source() == "file" and plain.friction is None
    assert cal.friction_source() == "identified: FRICTION.json"
    assert cal.sources["tau0"] == cal.sources["nu"] == "identified: FRICTION.json"
    assert cal.sources["bearings"] == "none" and "params" not in cal.sources
    assert list(cal.friction["coulomb_motor"]) == json.loads(path.read_text())["coulomb_motor"]
    common = ["zwidth", "lexos", "--stiffness", "1000:1000:1", "--damping", "0:0:1", "--modes", "compensated",
              "--scheduler", "none", "--horizon", "0.05", "--quiet", "--json"]
    assert _json(capsys, common)["friction_source"] == "file"
    assert _json(capsys, common + ["--friction", str(path)])["friction_source"] == "identified: FRICTION.json"


def test_a_differentials_motor_side_friction_is_kept_for_the_maps_and_refused_by_the_compensator(tmp_path,
                                                                                                  capsys):
    """FRICTION.json of a differential routing holds the motors' values: maps take them as they are; export
    compensator and zwidth refuse in one line (CalibrationError) instead of splitting them over branches that do
    not separate."""
    from tendyn.ident.calibrated import CalibrationError, calibrate

    dev = load_device(generate.write_cable_device(tmp_path, 4, seed=3, differential=True))
    path = _friction(dev, tmp_path / "FRICTION.json")
    cal = calibrate(dev, path)
    assert cal.losses is None and list(cal.friction["viscous_motor"]) == json.loads(path.read_text())["viscous_motor"]
    with pytest.raises(CalibrationError, match="motors'"):
        cal.transmission()
    doc = _json(capsys, ["maps", str(dev.path), "--friction", str(path), "--points", "2", "--json"])
    np.testing.assert_allclose(doc["viscous_motor_N_m_s_per_rad"], json.loads(path.read_text())["viscous_motor"])
    for argv in (["export", "compensator", str(dev.path), "--friction", str(path), "--out", str(tmp_path / "x.comp")],
                 ["zwidth", str(dev.path), "--friction", str(path), "--scheduler", "none"]):
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "serial routing" in err[0], err


def test_zwidth_refuses_friction_with_a_compensator_file(tmp_path, capsys):
    path = _friction(LEXOS, tmp_path / "FRICTION.json")
    for argv, option in ((["--friction", str(path), "--compensator", str(tmp_path / "x.comp")], "--friction"),
                         (["--shares", str(path)], "--shares")):
        capsys.readouterr()
        assert main(["zwidth", "lexos", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and option in err[0], err


def test_the_s0_pipeline_hands_the_calibrated_loss_model_to_every_run(monkeypatch):
    """fig7_experiment of a calibrated device: every hand run gets its one loss model (built once), not the
    document to decompose again."""
    from tendyn.ident.calibrated import calibrate
    from tendyn.pipelines import s0_compensation

    n = LEXOS.n_transmissions
    doc = {"device": LEXOS.name, "tau0": (np.eye(n) * 0.5).tolist(), "nu": (np.eye(n) * 2.0).tolist()}
    cal = calibrate(LEXOS, doc)
    seen = []

    class Stop(Exception):
        pass

    def hand_run(device, k, *, friction=None, **kw):
        seen.append(friction)
        if len(seen) == 2:
            raise Stop

    monkeypatch.setattr(s0_compensation, "hand_run", hand_run)
    with pytest.raises(Stop):
        s0_compensation.fig7_experiment(cal, over=(), walls=False)
    assert seen[0] is None and seen[1] is cal.losses
