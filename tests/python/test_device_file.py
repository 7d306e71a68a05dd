"""Device file (TOML, schema 1): loading, validation messages, the L-EXOS twin, routing arrays, docs."""

from __future__ import annotations

import copy
import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from tendyn.device import (
    Device,
    DeviceError,
    load_device,
)
from tendyn.device.load import _Parser
from tendyn.device.schema import ALL_FIELD_TABLES
from tendyn.devices import available, bundled

REPO = Path(__file__).resolve().parents[2]
LEXOS = bundled("lexos")
LABEL = re.compile(r"\[(SEED|INFERRED|ASSUMPTION)\]")


# --------------------------------------------------------------------------------------------------------
# a tiny TOML writer (inline tables only) so that tests edit a dict and write it back
# --------------------------------------------------------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def dumps(d: dict) -> str:
    return "".join(f"{k} = {_toml_value(v)}\n" for k, v in d.items())


def lexos_dict() -> dict:
    with LEXOS.open("rb") as fh:
        return tomllib.load(fh)


def mdh_dict() -> dict:
    """A small modified-DH device: two actuated revolute joints and a fixed frame (sigma = 2)."""
    base = lexos_dict()
    joints = [
        dict(name="q1", j=1, antecedent=0, mu=1, sigma=0, gamma=0.0, b=0.0, alpha=0.0, d=0.0,
             theta_offset=0.0, r=0.0, lower=-1.0, upper=1.0, mass=1.0, com=[0.1, 0.0, 0.0],
             inertia=[0.01, 0.01, 0.01, 0.0, 0.0, 0.0]),
        dict(name="q2", j=2, antecedent=1, mu=1, sigma=0, alpha=-1.5707963267948966, d=0.0, r=0.0,
             lower=-1.0, upper=1.0, mass=1.0, com=[0.0, 0.0, 0.1], inertia=[0.01, 0.01, 0.01, 0.0, 0.0, 0.0]),
        dict(name="tool", j=3, antecedent=2, mu=0, sigma=2, alpha=0.0, d=0.3, r=0.0),
    ]
    base["kinematics"] = {"convention": "mdh", "gravity": [0.0, 0.0, -9.81], "joints": joints}
    base["transmissions"] = base["transmissions"][:2]
    base["device"].pop("home_pose", None)          # L-EXOS's pose: one value per joint of the 4-joint arm
    return base


CEA = bundled("cea_branch")


def cea_dict() -> dict:
    """The CEA branch twin (S2): mdh tree with a cut joint, parallelogram constraints and capstan drives."""
    with CEA.open("rb") as fh:
        return tomllib.load(fh)


def write(tmp_path: Path, content, name: str = "lexos.toml") -> Path:
    p = tmp_path / name
    p.write_text(content if isinstance(content, str) else dumps(content), encoding="utf-8")
    return p


# --------------------------------------------------------------------------------------------------------
# L-EXOS
# --------------------------------------------------------------------------------------------------------

def test_lexos_loads():
    dev = load_device(LEXOS)
    assert isinstance(dev, Device)
    assert dev.name == "L-EXOS"
    assert dev.n_joints == 4
    assert dev.kinematics.convention == "dh"
    np.testing.assert_array_equal(dev.kinematics.gravity, [0.0, 0.0, -9.81])
    assert [t.joint for t in dev.transmissions] == [1, 2, 3, 4]
    assert [j.mass for j in dev.kinematics.joints] == [2.0, 2.0, 1.2, 0.8]
    assert dev.kinematics.joints[1].theta_offset == pytest.approx(-math.pi / 2)
    assert dev.kinematics.joints[2].d == 0.30 and dev.kinematics.joints[3].a == 0.32
    assert all(t.pretension == 50.0 and t.motor_radius == 0.008 for t in dev.transmissions)
    assert all(t.sensors.encoder_counts == 16384 for t in dev.transmissions)
    assert all(t.sensors.current_noise == pytest.approx(0.01 * t.motor.continuous_current)
               for t in dev.transmissions)
    assert all(t.bearings == (None,) * t.joint for t in dev.transmissions)


def test_C2_generalized_radius_is_pulley_times_reducer(claims_ctx):
    """C2 / S0 footnote 1: with a reducer in the driven pulley, r_i^i = r_pulley * n_i."""
    from tendyn.claims import assert_claim

    assert_claim("C2", claims_ctx)


def test_lexos_routing_arrays_consistent():
    dev = load_device(LEXOS)
    r = dev.routing_arrays()
    n = dev.n_joints
    K = r["K"]
    assert K.shape == (n, n)
    np.testing.assert_array_equal(K, np.tril(K))  # lower-triangular: a cable never reaches beyond its joint
    assert np.all(np.diag(K) > 0)  # nonsingular routing
    assert abs(np.linalg.det(K)) > 0
    # transmission i crosses joints 1..i-1 [SEED]: the strict lower triangle is fully populated with +-0.015
    below = K[np.tril_indices(n, -1)]
    np.testing.assert_allclose(np.abs(below), 0.015)
    np.testing.assert_allclose(K[3, :3], [0.015, -0.015, 0.015])
    for i, t in enumerate(dev.transmissions):
        for jn, rad in zip(t.crosses, t.crossed_radii):
            assert K[i, jn - 1] == rad
    for key in ("motor_radius", "driven_radius", "reducer_ratio", "reducer_efficiency", "pretension"):
        assert r[key].shape == (n,)
    np.testing.assert_allclose(r["driven_radius"] * r["reducer_ratio"], np.diag(K))
    np.testing.assert_allclose(r["reducer_efficiency"], [0.9, 0.9, 1.0, 0.9])
    np.testing.assert_allclose(r["reducer_ratio"], [8, 8, 1, 8])
    tril = np.tril(np.ones((n, n)))
    np.testing.assert_allclose(r["tau0"], 1.0 * tril)
    np.testing.assert_allclose(r["nu"], 10.0 * tril)
    np.testing.assert_allclose(r["beta"], 0.02 * tril)
    for name in ("count", "wrap", "static_coefficient", "dynamic_coefficient", "h0", "h1", "n0"):
        np.testing.assert_array_equal(r["bearing_" + name], np.zeros((n, n)))
    np.testing.assert_array_equal(r["bearing_radius"], np.ones((n, n)))


def test_lexos_lossless_virtual_work():
    """C2, C3 on the bundled L-EXOS file, through the core: the routing matrix is the one DEVICES.md
    describes (generalised radii 0.04·8, 0.04·8, 0.09, 0.03·8 m; idle pulleys ±0.015 m; motor pulleys
    8 mm), and the core's lossless statics conserve power: q̇ᵀ τ_J = q̇_mᵀ C_m (ERRATA eq. 5)."""
    from tendyn.transmission import Transmission

    dev = load_device(LEXOS)
    tr = Transmission.from_device(dev)
    K = tr.K
    np.testing.assert_allclose(np.diag(K), [0.32, 0.32, 0.09, 0.24], rtol=1e-15)
    low = K[np.tril_indices(4, -1)]
    np.testing.assert_allclose(np.abs(low), 0.015, rtol=1e-15)
    np.testing.assert_array_equal(np.triu(K, 1), 0.0)
    np.testing.assert_allclose(np.array(tr.model.motor_radius), 0.008, rtol=1e-15)
    rng = np.random.default_rng(1)
    for _ in range(20):
        qd, tau = rng.normal(size=4), rng.normal(size=4)
        qd_m = tr.motor_from_joint(qd)                      # the core's kinematics, not a solve here
        np.testing.assert_allclose(0.008 * qd_m, K @ qd, rtol=1e-12, atol=1e-15)
        cm = tr.feedforward(tau, losses=False).torque_motor
        assert qd @ tau == pytest.approx(qd_m @ cm, rel=1e-12, abs=1e-14)


def _dh(a, alpha, d, theta):
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lexos_com_geometry(seed):
    """The COM vectors put each COM where DEVICES.md says, for any configuration (forward kinematics)."""
    dev = load_device(LEXOS)
    q = np.random.default_rng(seed).uniform(-1, 1, 4)
    M, frames = np.eye(4), []
    for js, qi in zip(dev.kinematics.joints, q):
        M = M @ _dh(js.a, js.alpha, js.d, qi + js.theta_offset)
        frames.append(M.copy())
    com = [F[:3, :3] @ js.com + F[:3, 3] for F, js in zip(frames, dev.kinematics.joints)]
    shoulder, elbow, handle = np.zeros(3), frames[2][:3, 3], frames[3][:3, 3]
    assert np.linalg.norm(elbow - shoulder) == pytest.approx(0.30)
    assert np.linalg.norm(handle - elbow) == pytest.approx(0.32)
    arm, fore = elbow / 0.30, (handle - elbow) / 0.32
    np.testing.assert_allclose(com[1], 0.12 * arm, atol=1e-12)  # 0.12 m along the upper arm
    np.testing.assert_allclose(com[2], 0.26 * arm, atol=1e-12)  # 0.26 m from the shoulder, near the elbow
    np.testing.assert_allclose(com[3], elbow + 0.14 * fore, atol=1e-12)  # 0.14 m along the forearm
    assert np.linalg.norm(com[0][:2]) == pytest.approx(0.05)  # 0.05 m off axis 1 (z0)


def test_lexos_every_value_is_labelled():
    text = LEXOS.read_text(encoding="utf-8")
    text = re.sub(r'"""(.|\n)*?"""', '""', text)  # the multi-line description
    for line in text.splitlines():
        if re.match(r"^\s*[A-Za-z_]\w*\s*=", line) and not line.startswith(("schema", "description")):
            assert LABEL.search(line), f"value without [SEED]/[INFERRED]/[ASSUMPTION] label: {line!r}"
        if re.match(r"^\s*\{", line):  # per-branch friction entries: covered by the label of `friction = [`
            assert "branch" in line


def test_device_is_immutable():
    dev = load_device(LEXOS)
    with pytest.raises(AttributeError):
        dev.name = "x"  # type: ignore[misc]
    with pytest.raises(AttributeError):
        dev.transmissions[0].joint = 2  # type: ignore[misc]
    with pytest.raises(ValueError):
        dev.kinematics.gravity[2] = 0.0
    with pytest.raises(ValueError):
        dev.kinematics.joints[0].com[0] = 1.0


def test_bundled():
    assert "lexos" in available()
    assert bundled("lexos") == bundled("LEXOS.toml")
    assert bundled("lexos").is_file()


def test_bundled_unknown_lists_available():
    with pytest.raises(DeviceError, match="lexos") as ei:
        bundled("nope")
    assert "nope" in str(ei.value)
    assert isinstance(ei.value, ValueError)


# --------------------------------------------------------------------------------------------------------
# valid variations
# --------------------------------------------------------------------------------------------------------

def test_transmissions_sorted_by_driven_joint(tmp_path):
    d = lexos_dict()
    d["transmissions"] = d["transmissions"][::-1]
    dev = load_device(write(tmp_path, d))
    assert [t.name for t in dev.transmissions] == ["t1", "t2", "t3", "t4"]
    np.testing.assert_array_equal(dev.routing_arrays()["K"], load_device(LEXOS).routing_arrays()["K"])


def test_int_accepted_for_float_and_defaults(tmp_path):
    d = lexos_dict()
    t = d["transmissions"][0]
    t["pretension"] = 50  # int for float
    del t["reducer_ratio"], t["reducer_efficiency"]  # defaults 1.0
    t["friction"] = [{"tau0": 1, "nu": 10}]  # beta defaults to 0
    d["kinematics"]["gravity"] = [0, 0, -10]
    dev = load_device(write(tmp_path, d))
    t1 = dev.transmissions[0]
    assert t1.pretension == 50.0 and isinstance(t1.pretension, float)
    assert t1.reducer_ratio == 1.0 and t1.reducer_efficiency == 1.0
    assert t1.friction[0].beta == 0.0
    assert dev.kinematics.gravity.dtype == float


def test_self_locking_efficiency_is_kept(tmp_path):
    d = lexos_dict()
    d["transmissions"][0]["reducer_efficiency"] = 0.4
    t1 = load_device(write(tmp_path, d)).transmissions[0]
    assert t1.reducer_efficiency == 0.4
    assert t1.self_locking and t1.inverse_efficiency < 0


def test_bearings_parsed_into_arrays(tmp_path):
    d = lexos_dict()
    br = {"count": 2, "radius": 0.01, "wrap": 3.14159, "static_coefficient": 0.002, "dynamic_coefficient": 0.0015, "h0": 1e-4,
          "h1": 2e-5, "n0": 5.0}
    d["transmissions"][2]["bearings"] = [{}, br, {}]
    dev = load_device(write(tmp_path, d))
    t3 = dev.transmissions[2]
    assert t3.bearings[0] is None and t3.bearings[2] is None
    assert t3.bearings[1].count == 2 and t3.bearings[1].h1 == 2e-5
    r = dev.routing_arrays()
    assert r["bearing_count"][2, 1] == 2 and r["bearing_radius"][2, 1] == 0.01
    assert r["bearing_n0"][2, 1] == 5.0
    assert r["bearing_radius"][2, 0] == 1.0 and r["bearing_count"][2, 0] == 0


def test_mdh_loads(tmp_path):
    dev = load_device(write(tmp_path, mdh_dict()))
    assert dev.kinematics.convention == "mdh"
    assert dev.n_joints == 3 and dev.n_transmissions == 2
    tool = dev.kinematics.joints[2]
    assert tool.sigma == 2 and tool.mass == 0.0 and not tool.actuated
    assert dev.kinematics.joints[1].antecedent == 1
    assert dev.routing_arrays()["K"].shape == (2, 3)


def test_cea_branch_loads():
    dev = load_device(CEA)
    assert dev.kind == "serial" and dev.kinematics.convention == "mdh"
    assert dev.transmissions == () and [d.joint for d in dev.drives] == [1, 2, 5]
    assert [c.joint for c in dev.kinematics.constraints] == [3, 4, 6, 7]
    c4 = dev.kinematics.constraints[1]
    assert c4.terms == ((5, -1.0),) and c4.offset == pytest.approx(math.pi / 2)
    d2 = dev.drives[1]
    assert d2.ratio == 20.0 and d2.stiffness_motor == 2.0 and d2.servo_stiffness_motor == 2.0
    assert d2.coulomb_joint == pytest.approx(0.1240) and d2.viscous_joint == pytest.approx(0.032)
    assert d2.stiffness_joint == pytest.approx(800.0) and d2.total_stiffness_motor == pytest.approx(1.0)
    assert d2.offset_joint == 0.02 and dev.drives[0].offset_joint == 0.0
    assert dev.kinematics.joints[7].sigma == 2 and dev.kinematics.joints[7].d == pytest.approx(0.06)
    assert dev.routing_arrays()["K"].shape == (0, 8)
    assert load_device(LEXOS).drives == ()


def test_drive_defaults(tmp_path):
    d = cea_dict()
    for key in ("damping_motor", "coulomb_motor", "viscous_motor", "offset_joint", "servo_stiffness_motor",
                "name"):
        del d["drives"][0][key]
    d1 = load_device(write(tmp_path, d)).drives[0]
    assert (d1.damping_motor, d1.coulomb_motor, d1.viscous_motor, d1.offset_joint) == (0.0, 0.0, 0.0, 0.0)
    assert d1.servo_stiffness_motor is None and d1.total_stiffness_motor == 2.0 and d1.name == "drive1"


def test_kind_tendon_bench_is_delegated(tmp_path):
    """load_device hands a `kind = "tendon_bench_2n"` file to the bench loader: the bundled bench file comes
    back as the bench loader's TendonBench, and a serial-device body with that kind is judged by the bench
    loader's rules (a serial [kinematics] table is unknown to it), not by the serial validator (which
    accepts it)."""
    from tendyn.device.tendon_bench import TendonBench, load_tendon_bench

    bench = load_device(bundled("mcgill_bench"))
    assert type(bench) is TendonBench and bench == load_tendon_bench(bundled("mcgill_bench"))
    d = lexos_dict()
    load_device(write(tmp_path, d))                                   # valid as a serial device
    d["device"]["kind"] = "tendon_bench_2n"
    with pytest.raises(DeviceError) as ei:
        load_device(write(tmp_path, d))
    msg = str(ei.value)
    assert "kinematics: unknown field (known fields: schema, device, bench)" in msg, msg


URDF = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <axis xyz="0 0 1"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="fixed_tip" type="fixed"><parent link="l2"/><child link="tip"/></joint>
</robot>
"""


def test_urdf_convention(tmp_path):
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "two.urdf").write_text(URDF)
    d = lexos_dict()
    d["kinematics"] = {"convention": "urdf", "gravity": [0.0, 0.0, -9.81], "urdf": "robots/two.urdf"}
    d["transmissions"] = d["transmissions"][:2]
    d["device"].pop("home_pose", None)
    dev = load_device(write(tmp_path, d))
    assert dev.kinematics.urdf == (tmp_path / "robots" / "two.urdf").resolve()
    assert [j.name for j in dev.kinematics.joints] == ["j1", "j2"]  # chain order, not document order
    assert dev.kinematics.joints[1].lower == -0.5
    assert dev.routing_arrays()["K"].shape == (2, 2)


def test_docs_example_loads(tmp_path):
    text = (REPO / "docs" / "device-file.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    assert blocks
    dev = load_device(write(tmp_path, blocks[-1], "example.toml"))
    assert dev.n_joints == 2
    assert dev.transmissions[1].bearings[1].count == 2
    assert dev.routing_arrays()["K"][1, 0] == -0.012


def test_every_field_is_documented():
    text = (REPO / "docs" / "device-file.md").read_text(encoding="utf-8")
    for section, specs in ALL_FIELD_TABLES.items():
        for spec in specs:
            assert f"`{spec.name}`" in text, f"field {section}.{spec.name} missing from docs/device-file.md"
            assert spec.doc, f"field {section}.{spec.name} has no description"


# --------------------------------------------------------------------------------------------------------
# malformed files: one edit each, one clear DeviceError naming file, field and problem
# --------------------------------------------------------------------------------------------------------

def _edit(fn, base=lexos_dict):
    def make():
        d = copy.deepcopy(base())
        fn(d)
        return d
    return make


def _set(path: str, value, base=lexos_dict):
    """Set d[a][b]... (integers index lists, 0-based)."""
    keys = [int(k) if k.isdigit() else k for k in path.split("/")]

    def fn(d):
        obj = d
        for k in keys[:-1]:
            obj = obj[k]
        obj[keys[-1]] = value
    return _edit(fn, base)


def _del(path: str, base=lexos_dict):
    keys = [int(k) if k.isdigit() else k for k in path.split("/")]

    def fn(d):
        obj = d
        for k in keys[:-1]:
            obj = obj[k]
        del obj[keys[-1]]
    return _edit(fn, base)


def _drive_joint_1_twice(d):
    t2 = d["transmissions"][1]
    t2.update(joint=1, crosses=[], crossed_radii=[], friction=t2["friction"][:1])


def _urdf_with_joints(d):
    d["kinematics"]["convention"] = "urdf"
    d["kinematics"]["urdf"] = "x.urdf"


def _urdf_missing(d):
    d["kinematics"] = {"convention": "urdf", "gravity": [0.0, 0.0, -9.81], "urdf": "robots/missing.urdf"}


_SYNTAX = """schema = 1
[device]
name = "L-EXOS"
[kinematics
convention = "dh"
"""

MALFORMED = [
    # (id, content maker or raw TOML string or None for "no file", expected fragments)
    ("file_missing", None, ["missing.toml", "file not found"]),
    ("toml_syntax", _SYNTAX, ["TOML syntax error", "line 4"]),
    ("toml_duplicate_key", 'schema = 1\nschema = 1\n', ["TOML syntax error", "line 2"]),
    ("schema_version", _set("schema", 2), ["schema: unsupported schema version 2", "schema = 1"]),
    ("schema_missing", _del("schema"), ["schema: missing required field"]),
    ("schema_float", _set("schema", 1.0), ["schema: must be an integer (got float 1.0)"]),
    ("unknown_top", _set("transmission", []), ["transmission: unknown field", "did you mean 'transmissions'"]),
    ("unknown_nested", _set("transmissions/1/driven_raduis", 0.04),
     ["transmissions[2].driven_raduis: unknown field (did you mean 'driven_radius'?)"]),
    ("unknown_joint_field", _set("kinematics/joints/0/masss", 1.0),
     ["kinematics.joints[1].masss: unknown field (did you mean 'mass'?)"]),
    ("unknown_no_suggestion", _set("device/zzz", 1), ["device.zzz: unknown field", "known fields: name"]),
    ("missing_required", _del("transmissions/0/motor_radius"),
     ["transmissions[1].motor_radius: missing required field"]),
    ("missing_device_name", _del("device/name"), ["device.name: missing required field"]),
    ("missing_motor_table", _del("transmissions/3/motor"), ["transmissions[4].motor: missing required field"]),
    ("missing_friction", _del("transmissions/1/friction"), ["transmissions[2].friction: missing required"]),
    ("empty_name", _set("device/name", " "), ["device.name: must not be empty"]),
    ("bool_not_number", _set("kinematics/joints/0/mass", True),
     ["kinematics.joints[1].mass: must be a number (got boolean true)", "booleans are not numbers"]),
    ("string_not_number", _set("transmissions/1/driven_radius", "0.04"),
     ["transmissions[2].driven_radius: must be a number (got string '0.04')"]),
    ("float_not_int", _set("transmissions/0/sensors/encoder_counts", 16384.0),
     ["transmissions[1].sensors.encoder_counts: must be an integer (got float 16384.0)"]),
    ("bool_not_int", _set("transmissions/0/joint", True), ["transmissions[1].joint: must be an integer",
                                                            "boolean"]),
    ("table_not_list", _set("transmissions", {"name": "t1"}), ["transmissions: must be an array of tables"]),
    ("vec3_length", _set("kinematics/joints/1/com", [0.0, 0.12]),
     ["kinematics.joints[2].com: must be an array of 3 numbers", "got 2 elements"]),
    ("driven_radius_zero", _set("transmissions/1/driven_radius", 0.0),
     ["transmissions[2].driven_radius: must be > 0 (got 0.0): a zero driven radius makes the routing singular"]),
    ("motor_radius_negative", _set("transmissions/0/motor_radius", -0.008),
     ["transmissions[1].motor_radius: must be > 0 (got -0.008)"]),
    ("motor_radius_too_big", _set("transmissions/0/motor_radius", 2.0),
     ["transmissions[1].motor_radius: must be <= 1 (got 2.0)"]),
    ("mass_zero", _set("kinematics/joints/2/mass", 0.0), ["kinematics.joints[3].mass: must be > 0 (got 0.0)"]),
    ("alpha_too_big", _set("kinematics/joints/0/alpha", 7.0),
     ["kinematics.joints[1].alpha: must satisfy |value| <= 2*pi (got 7.0)"]),
    ("beta_one", _set("transmissions/2/friction/1/beta", 1.0),
     ["transmissions[3].friction[2].beta: must be in [0, 1) (got 1.0)"]),
    ("tau0_negative", _set("transmissions/2/friction/0/tau0", -1.0),
     ["transmissions[3].friction[1].tau0: must be >= 0 (got -1.0)"]),
    ("reducer_ratio_below_one", _set("transmissions/0/reducer_ratio", 0.5),
     ["transmissions[1].reducer_ratio: must be >= 1 (got 0.5)"]),
    ("pretension_negative", _set("transmissions/0/pretension", -5.0),
     ["transmissions[1].pretension: must be >= 0 (got -5.0)"]),
    ("encoder_zero", _set("transmissions/0/sensors/encoder_counts", 0),
     ["transmissions[1].sensors.encoder_counts: must be >= 1 (got 0)"]),
    ("efficiency_zero", _set("transmissions/0/reducer_efficiency", 0.0),
     ["transmissions[1].reducer_efficiency: must be in (0, 1] (got 0.0)"]),
    ("efficiency_above_one", _set("transmissions/3/reducer_efficiency", 1.1),
     ["transmissions[4].reducer_efficiency: must be in (0, 1] (got 1.1)"]),
    ("nan", _set("kinematics/joints/3/a", math.nan), ["kinematics.joints[4].a: must be finite (got nan)"]),
    ("inf", _set("kinematics/gravity", [0.0, 0.0, -math.inf]),
     ["kinematics.gravity[3]: must be finite (got -inf)"]),
    ("nan_in_list", _set("transmissions/3/crossed_radii", [0.015, math.nan, 0.015]),
     ["transmissions[4].crossed_radii[2]: must be finite (got nan)"]),
    ("gravity_norm", _set("kinematics/gravity", [0.0, 0.0, -981.0]),
     ["kinematics.gravity: norm must be <= 100 m/s^2 (got 981)"]),
    ("convention_unknown", _set("kinematics/convention", "DH"),
     ["kinematics.convention: must be one of 'dh', 'mdh', 'urdf' (got 'DH')"]),
    ("duplicate_joint_name", _set("kinematics/joints/1/name", "shoulder_abduction"),
     ["kinematics.joints[2].name: duplicate joint name 'shoulder_abduction' (also kinematics.joints[1])"]),
    ("duplicate_transmission_name", _set("transmissions/2/name", "t1"),
     ["transmissions[3].name: duplicate transmission name 't1'"]),
    ("lower_ge_upper", _set("kinematics/joints/2/lower", 1.2),
     ["kinematics.joints[3].lower: must be < upper (got lower = 1.2, upper = 1.0471975511965976)"]),
    ("lower_eq_upper", _set("kinematics/joints/3/upper", 0.0), ["kinematics.joints[4].lower: must be < upper"]),
    ("inertia_not_psd", _set("kinematics/joints/0/inertia", [0.01, 0.01, 0.01, 0.02, 0.0, 0.0]),
     ["kinematics.joints[1].inertia: not a physical inertia: not positive semidefinite"]),
    ("inertia_triangle", _set("kinematics/joints/1/inertia", [0.01, 0.01, 0.03, 0.0, 0.0, 0.0]),
     ["kinematics.joints[2].inertia: not a physical inertia", "Ixx + Iyy >= Izz"]),
    ("inertia_length", _set("kinematics/joints/1/inertia", [0.01, 0.01, 0.03]),
     ["kinematics.joints[2].inertia: must be an array of 6 numbers [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]"]),
    ("crosses_beyond_driven", _set("transmissions/1/crosses", [1, 4]),
     ["transmissions[2].crosses[2]: cannot reach joint 4: transmission t2 drives joint 2"]),
    ("crosses_own_joint", _set("transmissions/2/crosses", [1, 3]),
     ["transmissions[3].crosses[2]: cannot reach joint 3: transmission t3 drives joint 3"]),
    ("crosses_zero", _set("transmissions/1/crosses", [0]), ["transmissions[2].crosses[1]: must be a joint number >= 1"]),
    ("crosses_duplicate", _set("transmissions/3/crosses", [1, 1, 2]),
     ["transmissions[4].crosses[2]: joint 1 is listed twice"]),
    ("crossed_radii_length", _set("transmissions/2/crossed_radii", [0.015]),
     ["transmissions[3].crossed_radii: must have one radius per crossed joint", "crosses has 2 entries, "
      "crossed_radii has 1"]),
    ("crossed_radius_zero", _set("transmissions/2/crossed_radii", [0.015, 0.0]),
     ["transmissions[3].crossed_radii[2]: must be nonzero (got 0.0)"]),
    ("friction_length", _set("transmissions/2/friction", [{"tau0": 1.0, "nu": 10.0}] * 2),
     ["transmissions[3].friction: must have exactly 3 entries, one per branch", "got 2"]),
    ("friction_entry_not_table", _set("transmissions/0/friction", [1.0]),
     ["transmissions[1].friction[1]: must be a table (got float 1.0)"]),
    ("bearings_length", _set("transmissions/1/bearings", [{}]),
     ["transmissions[2].bearings: must have the same length as friction (2, one per branch), got 1"]),
    ("bearing_wrap", _set("transmissions/0/bearings", [{"count": 1, "radius": 0.01, "wrap": 7.0, "static_coefficient": 0.0,
                                                        "dynamic_coefficient": 0.0, "h0": 0.0, "h1": 0.0, "n0": 0.0}]),
     ["transmissions[1].bearings[1].wrap: must be in (0, 2*pi] (got 7.0)"]),
    ("bearing_missing_field", _set("transmissions/0/bearings", [{"count": 1}]),
     ["transmissions[1].bearings[1].radius: missing required field"]),
    ("joint_driven_twice", _edit(_drive_joint_1_twice),
     ["transmissions[2].joint: joint 1 is driven twice", "each joint must be driven exactly once"]),
    ("joint_not_driven", _edit(lambda d: d["transmissions"].pop()),
     ["transmissions: joint 4 (elbow_flexion) is not driven by any transmission"]),
    ("joint_does_not_exist", _set("transmissions/3/joint", 5), ["transmissions[4].joint: no joint 5: the device has 4 joints"]),
    ("no_transmissions", _set("transmissions", []), ["transmissions: must list at least one transmission"]),
    ("drive_peak_below_continuous", _set("drives/1/motor/peak_torque", 0.1, base=cea_dict),
     ["drives[2].motor.peak_torque: must be >= continuous_torque (got peak_torque = 0.1, "
      "continuous_torque = 0.15)"]),
    # diagonal triangle inequalities hold (0.01 + 0.01 >= 0.01), the principal moments 0.001, 0.01, 0.019 do not
    ("inertia_principal_triangle", _set("kinematics/joints/2/inertia", [0.01, 0.01, 0.01, 0.009, 0.0, 0.0]),
     ["kinematics.joints[3].inertia: not a physical inertia: principal moments 0.001, 0.01, 0.019 violate "
      "the triangle inequality"]),
    ("peak_below_continuous", _set("transmissions/0/motor/peak_torque", 0.5),
     ["transmissions[1].motor.peak_torque: must be >= continuous_torque (got peak_torque = 0.5, "
      "continuous_torque = 0.7)"]),
    ("urdf_path_missing", _edit(_urdf_missing), ["kinematics.urdf: URDF file not found", "missing.urdf"]),
    ("urdf_with_joints", _edit(_urdf_with_joints), ['kinematics.joints: not allowed with convention = "urdf"']),
    ("urdf_key_with_dh", _set("kinematics/urdf", "a.urdf"), ['kinematics.urdf: only allowed with convention = "urdf"']),
    ("dh_without_joints", _del("kinematics/joints"), ["kinematics.joints: missing required field"]),
    ("mdh_antecedent_ge_j", _set("kinematics/joints/1/antecedent", 2, base=mdh_dict),
     ["kinematics.joints[2].antecedent: must be < j = 2 (got 2)"]),
    ("mdh_j_position", _set("kinematics/joints/2/j", 4, base=mdh_dict),
     ["kinematics.joints[3].j: must equal the entry's position 3 (got 4)"]),
    ("mdh_sigma", _set("kinematics/joints/0/sigma", 3, base=mdh_dict),
     ["kinematics.joints[1].sigma: must be one of 0, 1, 2 (got 3)"]),
    ("mdh_missing_mass", _del("kinematics/joints/1/mass", base=mdh_dict),
     ["kinematics.joints[2].mass: missing required field: needed for sigma = 0"]),
    ("mdh_fixed_actuated", _set("kinematics/joints/2/mu", 1, base=mdh_dict),
     ["kinematics.joints[3].mu: must be 0 for a cut joint / fixed frame (sigma = 2)"]),
    ("mdh_drive_passive", _set("transmissions/1/joint", 3, base=mdh_dict),
     ["transmissions[2].joint: joint 3 (tool) is not actuated (mu = 0)"]),
    # device kind, closed-loop constraints and elastic capstan drives (CEA branch, S2)
    ("kind_unknown", _set("device/kind", "bench", base=cea_dict),
     ["device.kind: must be one of 'serial', 'tendon_bench_2n' (got 'bench')"]),
    ("mdh_actuated_massless", _set("kinematics/joints/0/mass", 0.0, base=cea_dict),
     ["kinematics.joints[1].mass: must be > 0 (got 0.0) for an actuated joint"]),
    ("constraint_on_active_joint", _set("kinematics/constraints/0/joint", 2, base=cea_dict),
     ["kinematics.constraints[1].joint: joint 2 (arm) is actuated (mu = 1)"]),
    ("constraint_on_cut_frame", _set("kinematics/constraints/0/joint", 8, base=cea_dict),
     ["kinematics.constraints[1].joint: joint 8 (cut_closure) is a cut joint / fixed frame (sigma = 2)"]),
    ("constraint_no_joint", _set("kinematics/constraints/0/joint", 9, base=cea_dict),
     ["kinematics.constraints[1].joint: no joint 9: the device has 8 joints"]),
    ("constraint_twice", _set("kinematics/constraints/2/joint", 3, base=cea_dict),
     ["kinematics.constraints[3].joint: joint 3 (forearm) is constrained twice (also kinematics.constraints[1])"]),
    ("constraint_missing", _edit(lambda d: d["kinematics"]["constraints"].pop(2), base=cea_dict),
     ["kinematics.constraints: joint 6 (rod) is passive (mu = 0) and has no constraint"]),
    ("constraint_term_passive", _set("kinematics/constraints/0/terms", {"3": 1.0}, base=cea_dict),
     ["kinematics.constraints[1].terms.3: joint 3 (forearm) is not an active joint"]),
    ("constraint_term_key", _set("kinematics/constraints/0/terms", {"q2": 1.0}, base=cea_dict),
     ["kinematics.constraints[1].terms.q2: key must be an active joint number written as a string"]),
    ("constraint_term_nan", _set("kinematics/constraints/0/terms", {"2": math.nan}, base=cea_dict),
     ["kinematics.constraints[1].terms.2: must be finite (got nan)"]),
    ("constraint_terms_empty", _set("kinematics/constraints/1/terms", {}, base=cea_dict),
     ["kinematics.constraints[2].terms: must have at least one active-joint coefficient"]),
    ("constraint_with_dh", _set("kinematics/constraints", [{"joint": 2, "terms": {"1": 1.0}}]),
     ['kinematics.constraints: only allowed with convention = "mdh" (got convention = "dh")']),
    ("drive_ratio_zero", _set("drives/0/ratio", 0.0, base=cea_dict), ["drives[1].ratio: must be > 0 (got 0.0)"]),
    ("drive_stiffness_negative", _set("drives/1/stiffness_motor", -2.0, base=cea_dict),
     ["drives[2].stiffness_motor: must be > 0 (got -2.0)"]),
    ("drive_coulomb_negative", _set("drives/0/coulomb_motor", -0.01, base=cea_dict),
     ["drives[1].coulomb_motor: must be >= 0 (got -0.01)"]),
    ("drive_viscous_nan", _set("drives/2/viscous_motor", math.nan, base=cea_dict),
     ["drives[3].viscous_motor: must be finite (got nan)"]),
    ("drive_servo_negative", _set("drives/2/servo_stiffness_motor", -1.0, base=cea_dict),
     ["drives[3].servo_stiffness_motor: must be >= 0 (got -1.0)"]),
    ("drive_passive_joint", _set("drives/0/joint", 3, base=cea_dict),
     ["drives[1].joint: joint 3 (forearm) is not actuated (mu = 0)"]),
    ("drive_twice", _set("drives/1/joint", 1, base=cea_dict),
     ["drives[2].joint: joint 1 is driven twice (also drives[1])"]),
    ("drive_missing_joint", _edit(lambda d: d["drives"].pop(), base=cea_dict),
     ["drives: joint 5 (lever) is not driven by any drive"]),
    ("drive_missing_motor", _del("drives/0/motor", base=cea_dict), ["drives[1].motor: missing required field"]),
    ("drive_motor_field", _set("drives/0/motor/torque_constant", 0.0, base=cea_dict),
     ["drives[1].motor.torque_constant: must be > 0 (got 0.0)"]),
    ("drives_and_transmissions", _edit(lambda d: d.update(transmissions=lexos_dict()["transmissions"][:1]),
                                       base=cea_dict),
     ["drives: not allowed together with [[transmissions]]"]),
    ("neither_drives_nor_transmissions", _del("drives", base=cea_dict),
     ["transmissions: missing required field", "[[drives]]"]),
    ("no_drives", _set("drives", [], base=cea_dict), ["drives: must list at least one drive"]),
]


@pytest.mark.parametrize("case_id, content, fragments", MALFORMED, ids=[c[0] for c in MALFORMED])
def test_malformed_device_file(tmp_path, case_id, content, fragments):
    if content is None:
        path = tmp_path / "missing.toml"
    else:
        path = write(tmp_path, content() if callable(content) else content)
    with pytest.raises(Exception) as ei:
        load_device(path)
    err = ei.value
    assert type(err) is DeviceError, f"{type(err).__name__}: {err}"  # never KeyError/TypeError/TOMLDecodeError
    msg = str(err)
    assert msg.startswith("lexos.toml: ") or content is None, msg
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"
    assert "\n" not in msg  # one message, one line
    assert err.__cause__ is None or isinstance(err.__cause__, DeviceError)


def test_error_has_file_and_field_attributes(tmp_path):
    d = lexos_dict()
    d["transmissions"][1]["driven_radius"] = 0.0
    with pytest.raises(DeviceError) as ei:
        load_device(write(tmp_path, d))
    assert ei.value.file == "lexos.toml"
    assert ei.value.field == "transmissions[2].driven_radius"
    assert "singular" in ei.value.problem
    assert isinstance(ei.value, ValueError)


def _leaves(obj, prefix=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, prefix + (k,))
    elif isinstance(obj, list) and obj and isinstance(obj[0], dict):
        for i, v in enumerate(obj):
            yield from _leaves(v, prefix + (i,))
    yield prefix


_JUNK = ["x", True, -1, 0, 0.0, 1e9, math.nan, -math.inf, [], [1, 2], {}, {"a": 1}]


def _field_path(path: tuple) -> str:
    """("transmissions", 1, "motor", "peak_torque") → "transmissions[2].motor.peak_torque" (the error's field)."""
    out = ""
    for k in path:
        out += f"[{k + 1}]" if isinstance(k, int) else (f".{k}" if out else k)
    return out


def _expected_problem(original, value) -> str | None:
    """The message fragment a junk value MUST produce in place of a scalar field, or None when the value may
    be valid there (then only the message format is checked). A number field rejects non-numbers and
    non-finite numbers; a string field rejects every non-string."""
    if isinstance(original, bool):
        return None
    if isinstance(original, (int, float)):
        if isinstance(value, bool):
            return "(got boolean true)"
        if isinstance(value, str):
            return "(got string 'x')"
        if isinstance(value, list):
            return "(got an array)"
        if isinstance(value, dict):
            return "(got a table)"
        if isinstance(value, float) and math.isnan(value):
            return "nan)"
        if isinstance(value, float) and math.isinf(value):
            return "-inf)"
        return None
    if isinstance(original, str) and not isinstance(value, str):
        return "must be a string (got "
    return None


@pytest.mark.parametrize("base", [lexos_dict, mdh_dict, cea_dict], ids=["dh", "mdh", "cea"])
def test_every_mutation_gives_device_error_or_loads(tmp_path, base):
    """Replace or delete every field of a valid file in turn (deterministic sweep). Each mutation must:
    raise a DeviceError (never another exception type) whose message starts with the file name; when the
    junk cannot be valid for that field (a non-number or non-finite number in a number field, a non-string
    in a string field) it MUST be rejected, at that field, with the type/finiteness message; a deleted field
    is either optional (the file loads) or reported as missing at that field. So a dropped check fails here."""
    original = base()
    parser = _Parser(tmp_path / "lexos.toml")
    load_device(write(tmp_path, original))  # the base itself is valid
    paths = [p for p in _leaves(original) if p]
    assert len(paths) > 50
    n_errors = n_strict = 0
    for path in paths:
        obj0 = original
        for k in path:
            obj0 = obj0[k]
        field = _field_path(path)
        for value in _JUNK + [None]:  # None = delete the field
            d = copy.deepcopy(original)
            obj = d
            for k in path[:-1]:
                obj = obj[k]
            if value is None:
                del obj[path[-1]]
            else:
                obj[path[-1]] = value
            must = None if value is None else _expected_problem(obj0, value)
            try:
                parser.device(d)  # the validator of load_device, minus TOML writing/reading (speed)
            except DeviceError as exc:
                n_errors += 1
                msg = str(exc)
                assert msg.startswith("lexos.toml: "), msg
                if must is not None:
                    n_strict += 1
                    assert exc.field == field and must in exc.problem, (field, value, msg)
                if value is None and "missing required field" in msg:
                    assert exc.field == field or field in msg, (field, msg)
            else:
                assert must is None, f"{field} = {value!r} was accepted (expected {must!r})"
    assert n_errors > len(paths) and n_strict > len(paths)


def test_home_pose_is_checked(tmp_path):
    """``[device] home_pose``: one value per joint, inside the limits, else one line naming the entry."""
    d = lexos_dict()
    assert load_device(write(tmp_path, d)).home_pose == (0.3, 1.6, 0.0, 0.5)
    d["device"]["home_pose"] = [0.3, 1.6, 0.0]
    with pytest.raises(DeviceError, match=r"device.home_pose: 3 values, the device has 4 joints"):
        load_device(write(tmp_path, d))
    d["device"]["home_pose"] = [0.3, 1.6, 0.0, 3.0]
    with pytest.raises(DeviceError, match=r"device.home_pose\[4\]: 3 rad is outside joint 4's limits"):
        load_device(write(tmp_path, d))
