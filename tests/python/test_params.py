"""One source of truth per parameter (issue 6, items 4-7): the declaration, the C++ table, the defaults, the
docs, read-only models, input checks, validation messages and the complete model through the C ABI."""

import ctypes
import re
from pathlib import Path

import numpy as np
import pytest

import tendyn
from tendyn import _core
from tendyn.device import load_device
from tendyn.device.schema import (BEARING_FIELDS, BEARING_PREFIX, FRICTION_FIELDS, LOSS_FIELD_NAMES,
                                  TRANSMISSION_MODEL_FIELDS)
from tendyn.device.tendon_bench import BENCH_FIELDS, BENCH_MODEL_FIELDS, BENCH_OPTIONAL, TendonBench
from tendyn.devices import bundled
from tendyn.sim.model import sim_model
from tendyn.sim.tendon_bench import bench_model
from tendyn.transmission import Transmission

REPO = Path(__file__).resolve().parents[2]


def _norm_unit(u: str) -> str:
    return u.replace("·", " ").replace("²", "^2").replace("\u2212", "-").strip()


def _md_table(text: str, heading: str) -> list[list[str]]:
    """Rows (cells stripped of backticks) of the first markdown table after ``heading``."""
    start = text.index(heading)
    rows = []
    for line in text[start:].splitlines()[1:]:
        if line.startswith("|"):
            cells = [c.strip().strip("`") for c in line.strip().strip("|").split("|")]
            if not set("".join(cells)) <= set("-: "):
                rows.append(cells)
        elif rows:
            break
    return rows[1:]  # without the header


@pytest.fixture(scope="module")
def lexos():
    return load_device(bundled("lexos"))


# ---- one declaration ----------------------------------------------------------------------------------

def test_cpp_parameter_table_equals_the_python_declaration():
    cpp = [(name, dims, unit) for name, dims, unit, _doc in _core.TransmissionModel.fields()]
    py = [(f.name, f.dims, f.unit) for f in TRANSMISSION_MODEL_FIELDS]
    assert cpp == py


def test_declaration_is_derived_from_the_schema_tables():
    assert [f.name for f in TRANSMISSION_MODEL_FIELDS if f.toml.startswith("transmissions.friction.")] == \
        [s.name for s in FRICTION_FIELDS]
    assert [f.name for f in TRANSMISSION_MODEL_FIELDS if f.toml.startswith("transmissions.bearings.")] == \
        [BEARING_PREFIX + s.name for s in BEARING_FIELDS]


def test_routing_arrays_keys_are_the_core_fields(lexos):
    assert list(lexos.routing_arrays()) == [f.name for f in TRANSMISSION_MODEL_FIELDS]


def test_docs_route_table_matches_the_declaration():
    rows = _md_table((REPO / "docs/naming.md").read_text(encoding="utf-8"), "## Parameter route")
    want = [[f.toml, f.attribute, f.name, "(m,)" if f.dims == 1 else "(m, n)", f.unit]
            for f in TRANSMISSION_MODEL_FIELDS]
    assert rows == want


@pytest.mark.parametrize("heading,specs", [("### `friction` entries", FRICTION_FIELDS),
                                           ("### `bearings` entries", BEARING_FIELDS)])
def test_docs_loss_tables_match_the_schema(heading, specs):
    rows = _md_table((REPO / "docs/device-file.md").read_text(encoding="utf-8"), heading)
    assert [(r[0], _norm_unit(r[2])) for r in rows] == [(s.name, _norm_unit(s.unit)) for s in specs]


def test_docs_routing_arrays_table_names_every_core_field():
    rows = _md_table((REPO / "docs/device-file.md").read_text(encoding="utf-8"), "## `SerialDevice.routing_arrays()`")
    documented = [name.strip().strip("`") for r in rows for name in r[0].split(",")]
    assert documented == [f.name for f in TRANSMISSION_MODEL_FIELDS]


def test_docs_bench_table_matches_bench_fields_and_defaults():
    rows = _md_table((REPO / "docs/device-file.md").read_text(encoding="utf-8"), "## `[bench]`")
    assert [r[0] for r in rows] == list(BENCH_FIELDS)
    default = TendonBench()
    for name, unit, _allowed, dflt, _doc in rows:
        assert _norm_unit(unit) == _norm_unit(BENCH_FIELDS[name][0]), name
        if name in BENCH_OPTIONAL:                  # a limit a file may leave out: no default, None
            assert dflt.strip() in ("—", "-") and getattr(default, name) is None, name
        else:
            assert float(dflt) == getattr(default, name), name


# ---- defaults agree -----------------------------------------------------------------------------------

def test_bench_defaults_cpp_equal_python():
    cpp, py = _core.TendonBenchModel(), TendonBench()
    for name in BENCH_MODEL_FIELDS:
        assert getattr(cpp, name) == getattr(py, name), name
    table = {name: (default, unit) for name, default, unit, _bound, _doc in _core.TendonBenchModel.fields()}
    for name in BENCH_MODEL_FIELDS:
        assert table[name] == (getattr(py, name), BENCH_FIELDS[name][0]), name
    assert not set(BENCH_OPTIONAL) & set(table)     # the limits are no plant parameters of the core
    assert list(BENCH_MODEL_FIELDS) == [n for n in BENCH_FIELDS if n not in BENCH_OPTIONAL]


def test_transmission_defaults_cpp_equal_python(lexos):
    n = 3
    model = _core.TransmissionModel({"motor_radius": np.full(n, 0.01), "K": np.eye(n) * 0.05,
                                     "driven_radius": np.full(n, 0.05)})
    for f in TRANSMISSION_MODEL_FIELDS:
        if f.name in ("motor_radius", "K", "driven_radius"):
            continue
        np.testing.assert_array_equal(np.array(getattr(model, f.name)),
                                      np.full((n, n) if f.dims == 2 else (n,), f.default), err_msg=f.name)
    # and a device without bearings gives exactly the defaults in its bearing arrays
    arr = lexos.routing_arrays()
    for f in TRANSMISSION_MODEL_FIELDS:
        if f.name.startswith(BEARING_PREFIX):
            np.testing.assert_array_equal(arr[f.name], f.default, err_msg=f.name)


# ---- read-only models ---------------------------------------------------------------------------------

def test_core_model_is_read_only(lexos):
    tr = Transmission.from_device(lexos)
    with pytest.raises(AttributeError, match=r"TransmissionModel.tau0 is read-only"):
        tr.model.tau0 = np.zeros((4, 4))
    with pytest.raises(ValueError, match="read-only"):
        tr.model.beta[2, 1] = 1.5
    with pytest.raises(ValueError, match="read-only"):
        tr.model.K[0, 0] = 0.0
    with pytest.raises(AttributeError):
        tr.model = None
    assert tr.model.beta[2, 1] == 0.02


def test_bench_model_revalidates_every_write():
    m = _core.TendonBenchModel()
    with pytest.raises(ValueError, match=r"TendonBenchModel.k1 = -1: must be finite and > 0 \[N/m\]"):
        m.k1 = -1.0
    assert m.k1 == TendonBench().k1
    with pytest.raises(TypeError):
        m.k1 = "2e4"


def test_friction_off_is_built_not_mutated(lexos):
    m = sim_model(lexos, friction=False)
    for name in LOSS_FIELD_NAMES:
        f = next(f for f in TRANSMISSION_MODEL_FIELDS if f.name == name)
        np.testing.assert_array_equal(np.array(getattr(m.tendon, name)), f.default, err_msg=name)
    np.testing.assert_array_equal(np.array(m.tendon.reducer_efficiency), 1.0)
    assert lexos.routing_arrays()["tau0"][0, 0] == 1.0  # the device is untouched


# ---- input checks -------------------------------------------------------------------------------------

def test_wrong_shapes_give_the_named_message(lexos):
    tr = Transmission.from_device(lexos)
    with pytest.raises(ValueError, match=re.escape("q_motor must be a 1-D array of 4 finite floats (got shape (4, 4))")):
        tr.joint_from_motor(np.zeros((4, 4)))
    with pytest.raises(ValueError, match=re.escape("torque_joint must be a 1-D array of 4 finite floats (got shape (3,))")):
        tr.feedforward([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=re.escape("qd must be a 1-D array of 4 finite floats (got shape (1, 4))")):
        tr.forward(np.zeros(4), qd=np.zeros((1, 4)))
    with pytest.raises(ValueError, match=re.escape("q must be a 1-D array of 4 finite floats (got NaN or Inf at index 2)")):
        tr.motor_from_joint([0.0, 0.0, np.nan, 0.0])


@pytest.mark.parametrize("bad", ["1.0", ["1", "2", "3", "4"], [1.0, "2", 3.0, 4.0], [True, False, True, False]])
def test_a_string_where_a_number_belongs_is_refused(lexos, bad):
    tr = Transmission.from_device(lexos)
    with pytest.raises(TypeError, match="torque_joint must be a 1-D array of 4 finite floats"):
        tr.feedforward(bad)


def test_bench_fill_refuses_strings():
    with pytest.raises(TypeError, match=r"TendonBench.k1 must be a number \(got str '2e4'\)"):
        bench_model(TendonBench().replace(k1="2e4"))


# ---- the core's validation names field and index ------------------------------------------------------

def _lexos_arrays(lexos, **changes):
    arr = lexos.routing_arrays()
    for key, (index, value) in changes.items():
        arr[key] = arr[key].copy()
        arr[key][index] = value
    return arr


@pytest.mark.parametrize("changes,message", [
    ({"beta": ((2, 1), 1.5)}, "beta[2,1] = 1.5: must be < 1"),
    ({"tau0": ((3, 0), -0.5)}, "tau0[3,0] = -0.5: must be >= 0"),
    ({"reducer_efficiency": ((0,), 1.2)}, "reducer_efficiency[0] = 1.2: must be in (0, 1]"),
    ({"bearing_count": ((3, 2), 2.0)}, "bearing_wrap[3,2] = 0: must be in (0, 2*pi]"),
    # a cable may wrap a joint after its driven one (a differential, issue 19), but then holds no reducer
    ({"K": ((0, 2), 0.01)}, "reducer_ratio[0] = 8: must be 1: the cable wraps joints after its driven joint"),
])
def test_core_validation_names_field_and_index(lexos, changes, message):
    arr = _lexos_arrays(lexos, **changes)
    with pytest.raises(ValueError, match=re.escape("invalid transmission model: " + message)):
        _core.TransmissionModel(arr)
    report = _core.validate_report(_core.TransmissionModel(lexos.routing_arrays()))
    assert report == []


# ---- the complete model through the C ABI -------------------------------------------------------------

def _c_library():
    path = Path(tendyn.__file__).parent / "lib" / "libtendyn_c.so"
    if not path.exists():
        pytest.skip(f"{path} not installed")
    lib = ctypes.CDLL(str(path))
    lib.tendyn_transmission_load.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_void_p), ctypes.c_char_p,
                                             ctypes.c_ulong]
    lib.tendyn_transmission_load.restype = ctypes.c_int
    dp = ctypes.POINTER(ctypes.c_double)
    for fn in (lib.tendyn_motor_torque_feedforward, lib.tendyn_joint_torque_forward):
        fn.argtypes = [ctypes.c_void_p, dp, dp, dp]
        fn.restype = ctypes.c_int
    lib.tendyn_transmission_destroy.argtypes = [ctypes.c_void_p]
    return lib


def _with_bearings(lexos) -> Transmission:
    arr = lexos.routing_arrays()
    for (i, b) in ((1, 1), (3, 2), (3, 3)):
        arr["bearing_count"][i, b] = 2
        arr["bearing_radius"][i, b] = 0.012
        arr["bearing_wrap"][i, b] = 2.5
        arr["bearing_static_coefficient"][i, b] = 2e-4
        arr["bearing_dynamic_coefficient"][i, b] = 1.5e-4
        arr["bearing_h0"][i, b] = 1e-4
        arr["bearing_h1"][i, b] = 2e-5
        arr["bearing_n0"][i, b] = 5.0
    arr["pretension"] = np.full(4, 40.0)
    return Transmission.from_arrays(arr["motor_radius"], arr["K"], arr["reducer_ratio"], arr["reducer_efficiency"],
                                    arr["pretension"], **{k: arr[k] for k in LOSS_FIELD_NAMES})


def test_c_abi_carries_the_complete_lexos_model_with_bearings(lexos, tmp_path):
    lib = _c_library()
    tr = _with_bearings(lexos)
    path = tmp_path / "lexos_bearings.model"
    tr.export(path)
    back = Transmission.load(path)
    for name, value in tr.to_dict().items():
        np.testing.assert_array_equal(back.to_dict()[name], value, err_msg=name)
    handle, msg = ctypes.c_void_p(), ctypes.create_string_buffer(512)
    assert lib.tendyn_transmission_load(str(path).encode(), ctypes.byref(handle), msg, 512) == 0, msg.value
    rng = np.random.default_rng(11)
    no_bearings = Transmission.from_device(lexos)
    differs = False
    try:
        for _ in range(50):
            tau, qd = rng.normal(size=4) * 3, rng.normal(size=4) * (rng.random() < 0.8)
            out = np.zeros(4)
            as_c = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))  # noqa: E731
            tau_c, qd_c = np.ascontiguousarray(tau), np.ascontiguousarray(qd)
            assert lib.tendyn_motor_torque_feedforward(handle, as_c(tau_c), as_c(qd_c), as_c(out)) >= 0
            np.testing.assert_allclose(out, tr.feedforward(tau, qd).torque_motor, rtol=1e-14, atol=0)
            differs |= not np.allclose(out, no_bearings.feedforward(tau, qd).torque_motor, rtol=1e-9)
            assert lib.tendyn_joint_torque_forward(handle, as_c(tau_c), as_c(qd_c), as_c(out)) >= 0
            np.testing.assert_allclose(out, tr.forward(tau, qd).torque_joint, rtol=1e-14, atol=0)
    finally:
        lib.tendyn_transmission_destroy(handle)
    assert differs, "the bearings did not reach the C ABI model"


def test_c_abi_load_names_file_line_and_field(lexos, tmp_path):
    lib = _c_library()
    path = tmp_path / "bad.model"
    Transmission.from_device(lexos).export(path)
    text = path.read_text().splitlines()
    k = next(i for i, ln in enumerate(text) if ln.startswith("beta "))
    values = text[k].split()
    values[1 + 2 * 4 + 1] = "1.5"  # beta[2,1]
    text[k] = " ".join(values)
    path.write_text("\n".join(text) + "\n")
    handle, msg = ctypes.c_void_p(), ctypes.create_string_buffer(512)
    assert lib.tendyn_transmission_load(str(path).encode(), ctypes.byref(handle), msg, 512) == -3
    assert msg.value.decode() == f"bad.model: line {k + 1}: beta[2,1] = 1.5: must be < 1 (no tension passes the branch)"
    with pytest.raises(ValueError, match=re.escape(f"bad.model: line {k + 1}: beta[2,1] = 1.5")):
        Transmission.load(path)


# ---- bindings only expose -----------------------------------------------------------------------------

def test_bindings_mirror_cpp_names():
    for gone in ("time_motor_torque_feedforward", "sim_step", "sim_run", "tendon_bench_step", "tendon_bench_run",
                 "tendon_bench_reset"):
        assert not hasattr(_core, gone), gone
    for name in ("step", "run", "reset"):
        assert hasattr(_core, name)
