"""Experiment logs: schema, Parquet/CSV round trips, validation messages, truth sidecar, atomic writes."""

from __future__ import annotations

import json
import os
import random
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import tendyn
from tendyn.io import files as files_mod
from tendyn.io.logs import (
    COLUMNS,
    META_KEYS,
    Log,
    LogError,
    column_spec,
    make_log,
    read_log,
    read_truth,
    truth_path,
    write_log,
    write_truth,
)

DOCS = Path(__file__).resolve().parents[2] / "docs" / "logs.md"


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def awkward_values(rng, n):
    """Floats that a lossy text format would not survive."""
    special = np.array([0.0, -0.0, 0.1, 1 / 3, np.pi, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
                        -1e-300, 123456789.12345679, 1 - 2 ** -53, 2 ** 53 + 2.0])
    vals = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)
    vals[: min(n, special.size)] = special[: min(n, special.size)]
    return vals


def full_log(rng, n=200) -> Log:
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, n))  # irregular, strictly increasing
    cols = {"time": t}
    for i in (1, 2):
        cols[f"q_motor_{i}"] = awkward_values(rng, n)
        cols[f"qd_motor_{i}"] = rng.standard_normal(n)
        cols[f"torque_motor_{i}"] = rng.standard_normal(n)
        cols[f"torque_motor_cmd_{i}"] = rng.standard_normal(n)
        cols[f"current_{i}"] = rng.standard_normal(n)
        cols[f"q_motor_ref_{i}"] = rng.standard_normal(n)
        cols[f"qd_motor_ref_{i}"] = rng.standard_normal(n)
    for j in (1, 2):
        cols[f"q_joint_{j}"] = rng.standard_normal(n)
        cols[f"qd_joint_{j}"] = rng.standard_normal(n)
        cols[f"q_ref_{j}"] = rng.standard_normal(n)
        cols[f"qd_ref_{j}"] = rng.standard_normal(n)
        cols[f"torque_joint_ext_{j}"] = rng.standard_normal(n)
    for name in ("force_cmd", "force_tendon", "x_tendon", "current_cmd"):
        cols[name] = rng.standard_normal(n)
    return make_log(cols, device="lexos", rate_hz=1000.0, seed=20261122, experiment="chirp",
                    options={"amplitude_rad": 0.25, "band_hz": [0.1, 40.0], "label": "α/β ✓", "nested": {"k": None}})


def small_log(n=5) -> Log:
    t = np.arange(n) * 1e-3
    return make_log({"time": t, "q_motor_1": np.sin(t), "torque_motor_1": np.cos(t)}, device="lexos",
                    rate_hz=1000.0, seed=None, experiment="static")


# ----------------------------------------------------------------------------------------------------------
# Round trips
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_round_trip_bit_exact(tmp_path, rng, suffix):
    log = full_log(rng)
    path = write_log(log, tmp_path / f"run{suffix}")
    assert path == tmp_path / f"run{suffix}"
    back = read_log(path)
    assert list(back.columns) == list(log.columns)
    for name in log.columns:
        assert back[name].dtype == np.float64
        assert np.array_equal(back[name], log[name]), name
        assert np.array_equal(bits(back[name]), bits(log[name])), name  # also the sign of -0.0
    assert back.meta == log.meta
    assert back == log
    assert back.units == log.units
    # the arrays read back are the caller's to modify
    back["q_motor_1"][0] = 42.0


def test_meta_contents(rng):
    log = full_log(rng, n=3)
    assert list(log.meta) == list(META_KEYS)
    assert log.meta["schema"] == 1
    assert log.meta["created_by"] == f"tendyn {tendyn.__version__}"
    assert isinstance(log.meta["rate_hz"], float)


def test_csv_layout(tmp_path):
    path = write_log(small_log(3), tmp_path / "run.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("# tendyn-log {")
    meta = json.loads(lines[0][len("# tendyn-log "):])
    assert meta["device"] == "lexos"
    assert lines[1] == "time [s],q_motor_1 [rad],torque_motor_1 [N·m]"
    assert lines[2].split(",")[0] == "0.0"
    assert len(lines) == 2 + 3


def test_parquet_layout(tmp_path):
    path = write_log(small_log(3), tmp_path / "run.parquet")
    schema = pq.read_schema(path)
    meta = json.loads(schema.metadata[b"tendyn"].decode("utf-8"))
    assert meta["experiment"] == "static"
    assert schema.names == ["time", "q_motor_1", "torque_motor_1"]
    assert all(schema.field(n).type == pa.float64() for n in schema.names)
    assert schema.field("torque_motor_1").metadata[b"unit"] == "N·m".encode("utf-8")


def test_csv_by_hand_is_read(tmp_path):
    """A hand-written CSV: CRLF, extra comments, spaces, ASCII unit spelling, integers."""
    meta = dict(small_log().meta)
    text = ("# recorded on bench 3\r\n"
            f"# tendyn-log {json.dumps(meta)}\r\n"
            "time [s], q_motor_1 [rad], torque_motor_1 [N.m]\r\n"
            "0, 1, 2\r\n0.001, 1.5e-3, -2\r\n\r\n")
    p = tmp_path / "hand.csv"
    p.write_bytes(text.encode("utf-8"))
    log = read_log(p)
    assert np.array_equal(log.time, [0.0, 0.001])
    assert np.array_equal(log["torque_motor_1"], [2.0, -2.0])


def test_parquet_integer_columns_are_read(tmp_path):
    meta = dict(small_log().meta, rate_hz=1.0)      # integer seconds: 1 Hz (the rate must match the time column)
    table = pa.table({"time": pa.array([0, 1, 2], pa.int64()), "q_motor_1": pa.array([0.0, 1.0, 2.0], pa.float32())})
    table = table.replace_schema_metadata({b"tendyn": json.dumps(meta).encode()})
    p = tmp_path / "ints.parquet"
    pq.write_table(table, p)
    log = read_log(p)
    assert log.time.dtype == np.float64 and np.array_equal(log.time, [0.0, 1.0, 2.0])


def test_large_parquet(tmp_path, rng):
    n = 200_000
    cols = {"time": np.arange(n) / 1000.0}
    cols.update({f"q_motor_{i}": rng.standard_normal(n) for i in range(1, 12)})
    log = make_log(cols, device="d", rate_hz=1000.0, seed=1, experiment="e")
    back = read_log(write_log(log, tmp_path / "big.parquet"))
    assert back == log and back.n_samples == n


# ----------------------------------------------------------------------------------------------------------
# The Log object
# ----------------------------------------------------------------------------------------------------------

def test_column_names_and_stack_order():
    n = 4
    indices = list(range(1, 13))
    random.Random(3).shuffle(indices)
    cols = {"time": np.arange(n, dtype=float)}
    for i in indices:
        cols[f"q_motor_{i}"] = np.full(n, float(i))
    cols["q_motor_ref_1"] = np.zeros(n)  # another prefix: must not be picked up
    cols["qd_motor_1"] = np.zeros(n)
    log = make_log(cols, device="d", rate_hz=1.0, seed=None, experiment="e")
    names = log.column_names("q_motor_")
    assert names == [f"q_motor_{i}" for i in range(1, 13)]
    assert names.index("q_motor_10") == names.index("q_motor_9") + 1
    s = log.stack("q_motor_")
    assert s.shape == (n, 12) and s.dtype == np.float64
    assert np.array_equal(s[0], np.arange(1, 13, dtype=float))
    assert log.column_names("q_motor_ref_") == ["q_motor_ref_1"]
    assert log.column_names("q_joint_") == []
    with pytest.raises(LogError, match="no column q_joint_<i>"):
        log.stack("q_joint_")


def test_stack_refuses_gaps():
    t = np.arange(3.0)
    log = make_log({"time": t, "q_joint_1": t, "q_joint_3": t}, device="d", rate_hz=1.0, seed=None, experiment="e")
    assert log.column_names("q_joint_") == ["q_joint_1", "q_joint_3"]
    with pytest.raises(LogError, match="missing q_joint_2"):
        log.stack("q_joint_")


def test_log_accessors(rng):
    log = full_log(rng, n=7)
    assert log.n_samples == 7
    assert log.time is log["time"]
    assert "q_motor_1" in log and "q_motor_9" not in log
    with pytest.raises(KeyError, match="q_motor_9"):
        log["q_motor_9"]
    assert log.units["time"] == "s"
    assert log.units["torque_motor_cmd_2"] == "N·m"
    assert log.units["x_tendon"] == "m"
    d = log.to_dict()
    assert json.loads(json.dumps(d)) == d
    assert list(d["columns"]) == list(log.columns) and d["meta"] == log.meta
    assert log.validate() is log


def test_make_log_converts():
    log = make_log({"q_motor_1": [1, 2, 3], "time": np.array([0, 1, 2], dtype=np.int32)}, device="d",
                   rate_hz=np.float32(1), seed=np.int64(7), experiment="e",
                   options={"gains": (1, 2), "k": np.float64(0.5), "arr": np.arange(2)})
    assert list(log.columns) == ["time", "q_motor_1"]
    assert all(a.dtype == np.float64 for a in log.columns.values())
    assert log.meta["seed"] == 7 and type(log.meta["seed"]) is int
    assert log.meta["rate_hz"] == 1.0 and type(log.meta["rate_hz"]) is float
    assert log.meta["options"] == {"gains": [1, 2], "k": 0.5, "arr": [0, 1]}
    src = np.zeros(3)
    log2 = make_log({"time": np.arange(3.0), "q_motor_1": src}, device="d", rate_hz=1.0, seed=None, experiment="e")
    log2["q_motor_1"][0] = 1.0
    assert src[0] == 0.0  # make_log copies


@pytest.mark.parametrize("kwargs, fragment", [
    (dict(rate_hz=0.0), "meta.rate_hz"),
    (dict(rate_hz=float("nan")), "meta.rate_hz"),
    (dict(seed=True), "meta.seed"),
    (dict(seed=1.5), "meta.seed"),
    (dict(device=3), "meta.device"),
    (dict(experiment=""), "meta.experiment"),
    (dict(options={"x": float("nan")}), "meta.options"),
    (dict(options=[1]), "meta.options"),
])
def test_make_log_rejects_meta(kwargs, fragment):
    args = dict(device="d", rate_hz=1.0, seed=None, experiment="e")
    args.update(kwargs)
    with pytest.raises(LogError, match=fragment):
        make_log({"time": np.arange(3.0)}, **args)


# ----------------------------------------------------------------------------------------------------------
# Malformed logs: one clear message naming the file, the column and the row
# ----------------------------------------------------------------------------------------------------------

GOOD_META = {"schema": 1, "device": "lexos", "rate_hz": 1000.0, "seed": None, "experiment": "static",
             "options": {}, "created_by": "tendyn test"}
GOOD_HEADER = "time [s],q_motor_1 [rad],torque_motor_1 [N·m]"
GOOD_ROWS = ["0.0,0.1,1.0", "0.001,0.2,2.0", "0.002,0.3,3.0", "0.003,0.4,4.0"]


def csv_file(tmp_path, *, meta=GOOD_META, header=GOOD_HEADER, rows=GOOD_ROWS, meta_line=None):
    lines = [meta_line if meta_line is not None else "# tendyn-log " + json.dumps(meta), header, *rows]
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def meta_with(**kw):
    m = dict(GOOD_META)
    for k, v in kw.items():
        if v is _DROP:
            del m[k]
        else:
            m[k] = v
    return m


_DROP = object()


def parquet_file(tmp_path, arrays: dict, meta=GOOD_META):
    table = pa.table(arrays)
    if meta is not None:
        table = table.replace_schema_metadata({b"tendyn": json.dumps(meta).encode()})
    p = tmp_path / "bad.parquet"
    pq.write_table(table, p)
    return p


def parquet_with_units(tmp_path, units: dict, meta=GOOD_META):
    """A Parquet log whose columns carry the given unit strings in their Arrow field metadata."""
    fields = [pa.field(name, pa.float64(), metadata={b"unit": unit.encode()}) for name, unit in units.items()]
    table = pa.table({name: [0.0, 1.0] for name in units}, schema=pa.schema(fields))
    table = table.replace_schema_metadata({b"tendyn": json.dumps(meta).encode()})
    p = tmp_path / "bad.parquet"
    pq.write_table(table, p)
    return p


def rows_with(i, row):
    rows = list(GOOD_ROWS)
    rows[i] = row
    return rows


MALFORMED = [
    # (id, builder(tmp_path) -> Path or Log, fragments that must all appear in the message)
    ("csv-no-time", lambda d: csv_file(d, header="q_motor_1 [rad],torque_motor_1 [N·m],current_1 [A]"),
     ["bad.csv", "column time", "missing the required column time"]),
    ("csv-time-not-first", lambda d: csv_file(d, header="q_motor_1 [rad],time [s],torque_motor_1 [N·m]"),
     ["bad.csv", "column time", "first column is q_motor_1"]),
    ("csv-unknown-column", lambda d: csv_file(d, header="time [s],q_motr_1 [rad],torque_motor_1 [N·m]"),
     ["bad.csv", "unknown column 'q_motr_1'", "did you mean q_motor_1"]),
    ("csv-index-zero", lambda d: csv_file(d, header="time [s],q_motor_0 [rad],torque_motor_1 [N·m]"),
     ["bad.csv", "'q_motor_0'", "1-based"]),
    ("csv-duplicate", lambda d: csv_file(d, header="time [s],q_motor_1 [rad],q_motor_1 [rad]"),
     ["bad.csv", "column q_motor_1", "duplicate"]),
    ("csv-unit-disagrees", lambda d: csv_file(d, header="time [s],q_motor_1 [deg],torque_motor_1 [N·m]"),
     ["bad.csv", "column q_motor_1: unit 'deg' in the file, expected 'rad'"]),
    ("csv-unit-missing", lambda d: csv_file(d, header="time [s],q_motor_1,torque_motor_1 [N·m]"),
     ["bad.csv", "column q_motor_1", "line 2", "no unit"]),
    ("csv-wrong-cell-count", lambda d: csv_file(d, rows=rows_with(2, "0.002,0.3")),
     ["bad.csv", "row 2 (line 5)", "2 cells, the header has 3"]),
    ("csv-unparsable", lambda d: csv_file(d, rows=rows_with(1, "0.001,abc,2.0")),
     ["bad.csv", "column q_motor_1, row 1 (line 4)", "cannot read 'abc'"]),
    ("csv-empty-cell", lambda d: csv_file(d, rows=rows_with(3, "0.003,0.4,")),
     ["bad.csv", "column torque_motor_1, row 3 (line 6)", "cannot read ''"]),
    ("csv-nan", lambda d: csv_file(d, rows=rows_with(3, "0.003,0.4,nan")),
     ["bad.csv", "column torque_motor_1, row 3 (line 6, time 0.003 s)", "nan is not finite"]),
    ("csv-inf-time", lambda d: csv_file(d, rows=rows_with(1, "inf,0.2,2.0")),
     ["bad.csv", "column time, row 1 (line 4)", "inf is not finite"]),
    ("csv-time-decreasing", lambda d: csv_file(d, rows=rows_with(2, "0.0005,0.3,3.0")),
     ["bad.csv", "column time, row 2 (line 5)", "not strictly increasing"]),
    ("csv-time-repeated", lambda d: csv_file(d, rows=rows_with(1, "0.0,0.2,2.0")),
     ["bad.csv", "column time, row 1", "not strictly increasing"]),
    ("csv-empty", lambda d: csv_file(d, rows=[]), ["bad.csv", "empty log"]),
    ("csv-no-meta-line", lambda d: csv_file(d, meta_line="# just a comment"),
     ["bad.csv", "no '# tendyn-log"]),
    ("csv-meta-not-json", lambda d: csv_file(d, meta_line="# tendyn-log {schema: 1"),
     ["bad.csv", "meta", "line 1", "not valid JSON"]),
    ("csv-meta-missing-key", lambda d: csv_file(d, meta=meta_with(rate_hz=_DROP)),
     ["bad.csv", "meta", "missing key(s) rate_hz"]),
    ("csv-meta-unknown-key", lambda d: csv_file(d, meta=meta_with(truth={"k": 1})),
     ["bad.csv", "meta", "unknown key(s) truth"]),
    ("csv-rate-zero", lambda d: csv_file(d, meta=meta_with(rate_hz=0)), ["bad.csv", "meta.rate_hz", "> 0"]),
    ("csv-rate-string", lambda d: csv_file(d, meta=meta_with(rate_hz="1kHz")), ["bad.csv", "meta.rate_hz", "str"]),
    ("csv-seed-wrong-type", lambda d: csv_file(d, meta=meta_with(seed="abc")), ["bad.csv", "meta.seed"]),
    ("csv-schema-2", lambda d: csv_file(d, meta=meta_with(schema=2)), ["bad.csv", "meta.schema", "schema 2"]),
    ("csv-options-list", lambda d: csv_file(d, meta=meta_with(options=[1, 2])), ["bad.csv", "meta.options"]),
    ("parquet-string-column",
     lambda d: parquet_file(d, {"time": [0.0, 1.0], "q_motor_1": ["a", "b"]}),
     ["bad.parquet", "column q_motor_1", "Arrow type string is not floating or integer"]),
    ("parquet-unit-disagrees", lambda d: parquet_with_units(d, {"time": "s", "q_motor_1": "deg"}),
     ["bad.parquet", "column q_motor_1: unit 'deg' in the file, expected 'rad'"]),
    ("parquet-time-unit", lambda d: parquet_with_units(d, {"time": "ms", "q_motor_1": "rad"}),
     ["bad.parquet", "column time: unit 'ms' in the file, expected 's'"]),
    ("memory-options-tuple", lambda d: Log({"time": np.arange(2.0)}, meta_with(options={"a": (1, 2)})),
     ["<memory>", "meta.options", "does not survive a JSON round trip"]),
    ("memory-options-int-key", lambda d: Log({"time": np.arange(2.0)}, meta_with(options={1: "x"})),
     ["<memory>", "meta.options", "does not survive a JSON round trip"]),
    ("parquet-no-meta", lambda d: parquet_file(d, {"time": [0.0, 1.0]}, meta=None),
     ["bad.parquet", "no 'tendyn' meta"]),
    ("parquet-inf", lambda d: parquet_file(d, {"time": [0.0, 0.5, 1.0], "q_motor_1": [0.0, 1.0, np.inf]}),
     ["bad.parquet", "column q_motor_1, row 2 (time 1.0 s)", "inf is not finite"]),
    ("parquet-null", lambda d: parquet_file(d, {"time": [0.0, 0.5, 1.0], "q_motor_1": [0.0, None, 1.0]}),
     ["bad.parquet", "column q_motor_1, row 1", "missing value"]),
    ("parquet-time-not-first", lambda d: parquet_file(d, {"q_motor_1": [0.0, 1.0], "time": [0.0, 1.0]}),
     ["bad.parquet", "column time", "first column is q_motor_1"]),
    ("parquet-unknown", lambda d: parquet_file(d, {"time": [0.0, 1.0], "torque_joint_1": [0.0, 1.0]}),
     ["bad.parquet", "unknown column 'torque_joint_1'"]),
    ("parquet-garbage", lambda d: (d / "bad.parquet").write_bytes(b"not parquet") and d / "bad.parquet",
     ["bad.parquet", "not a readable Parquet file"]),
    ("memory-length-mismatch",
     lambda d: Log({"time": np.arange(5.0), "q_motor_1": np.zeros(3)}, dict(GOOD_META)),
     ["<memory>", "column q_motor_1", "has 3 values but time has 5"]),
    ("memory-int-dtype", lambda d: Log({"time": np.arange(5)}, dict(GOOD_META)),
     ["<memory>", "column time", "float64"]),
    ("memory-2d", lambda d: Log({"time": np.arange(5.0), "current_1": np.zeros((5, 1))}, dict(GOOD_META)),
     ["column current_1", "1-D"]),
    ("memory-no-columns", lambda d: Log({}, dict(GOOD_META)), ["<memory>", "no columns"]),
    ("memory-meta-not-dict", lambda d: Log({"time": np.arange(2.0)}, None), ["<memory>", "meta must be a dict"]),
]


@pytest.mark.parametrize("build, fragments", [pytest.param(b, f, id=i) for i, b, f in MALFORMED])
def test_malformed_logs(tmp_path, build, fragments):
    target = build(tmp_path)
    with pytest.raises(LogError) as info:
        if isinstance(target, Log):
            target.validate()
        else:
            read_log(target)
    msg = str(info.value)
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"
    assert "\n" not in msg


def test_error_attributes(tmp_path):
    p = csv_file(tmp_path, rows=rows_with(3, "0.003,0.4,nan"))
    with pytest.raises(LogError) as info:
        read_log(p)
    err = info.value
    assert (err.file, err.column, err.row, err.line) == (str(p), "torque_motor_1", 3, 6)
    assert isinstance(err, ValueError)


def test_unknown_suffix(tmp_path):
    with pytest.raises(LogError, match=r"run\.txt.*\.parquet or \.csv"):
        write_log(small_log(), tmp_path / "run.txt")
    with pytest.raises(LogError, match="unknown log format"):
        read_log(tmp_path / "run.json")
    assert not list(tmp_path.iterdir())


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.parquet"):
        read_log(tmp_path / "nope.parquet")


def test_write_validates_first(tmp_path):
    bad = Log({"time": np.array([0.0, 0.0])}, dict(GOOD_META))
    with pytest.raises(LogError, match=r"out\.csv: column time, row 1"):
        write_log(bad, tmp_path / "out.csv")
    assert not list(tmp_path.iterdir())


# ----------------------------------------------------------------------------------------------------------
# Ground truth sidecar
# ----------------------------------------------------------------------------------------------------------

def test_truth_path():
    assert truth_path("data/run.parquet") == Path("data/run.truth.json")
    assert truth_path(Path("/x/run.csv")) == Path("/x/run.truth.json")
    assert truth_path("a.b.csv") == Path("a.b.truth.json")


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_truth_beside_not_inside(tmp_path, rng, suffix):
    log = full_log(rng, n=20)
    path = write_log(log, tmp_path / f"run{suffix}")
    truth = {"stiffness_motor_secret": np.array([1.5e3, 2.5e3]), "tau0_secret": np.float64(0.012),
             "n_joints_secret": np.int64(2), "twin": "lexos"}
    tp = write_truth(truth, path)
    assert tp == tmp_path / "run.truth.json" and tp.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"run{suffix}", "run.truth.json"])
    back = read_truth(path)
    assert back == {"stiffness_motor_secret": [1500.0, 2500.0], "tau0_secret": 0.012, "n_joints_secret": 2,
                    "twin": "lexos"}
    raw = path.read_bytes()
    for key in truth:
        if key.endswith("_secret"):
            assert key.encode() not in raw
    again = read_log(path)
    assert again == log
    assert "secret" not in json.dumps(again.meta)


def test_read_truth_missing(tmp_path):
    write_log(small_log(), tmp_path / "measured.csv")
    with pytest.raises(FileNotFoundError, match="measured.truth.json"):
        read_truth(tmp_path / "measured.csv")


def test_truth_must_be_json(tmp_path):
    with pytest.raises(LogError, match="run.truth.json"):
        write_truth({"x": float("nan")}, tmp_path / "run.parquet")
    with pytest.raises(LogError, match="truth must be a dict"):
        write_truth([1, 2], tmp_path / "run.parquet")
    assert not list(tmp_path.iterdir())
    (tmp_path / "run.truth.json").write_text("[1, 2]")
    with pytest.raises(LogError, match="expected a JSON object"):
        read_truth(tmp_path / "run.parquet")


# ----------------------------------------------------------------------------------------------------------
# Atomic writes
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_no_temp_files_left(tmp_path, suffix):
    path = write_log(small_log(), tmp_path / "sub" / f"run{suffix}")
    write_log(small_log(7), path)  # overwrite
    write_truth({"a": 1}, path)
    assert sorted(p.name for p in path.parent.iterdir()) == sorted([path.name, "run.truth.json"])
    assert read_log(path).n_samples == 7


class _HalfWriter:
    """A file object that writes half of the data, then fails (disk full)."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, data):
        self.fh.write(data[: len(data) // 2])
        self.fh.flush()
        raise OSError(28, "No space left on device (simulated)")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.fh.close()
        return False


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
@pytest.mark.parametrize("failure", ["mid-write", "rename"])
def test_failed_write_keeps_old_file(tmp_path, monkeypatch, suffix, failure):
    path = write_log(small_log(5), tmp_path / f"run{suffix}")
    truth = write_truth({"k": 1.0}, path)
    old_log, old_truth = path.read_bytes(), truth.read_bytes()

    if failure == "mid-write":
        real_fdopen = os.fdopen
        monkeypatch.setattr(files_mod.os, "fdopen", lambda fd, mode: _HalfWriter(real_fdopen(fd, mode)))
    else:
        def boom(src, dst):
            raise OSError("rename failed (simulated)")
        monkeypatch.setattr(files_mod.os, "replace", boom)

    with pytest.raises(OSError, match="simulated"):
        write_log(small_log(50), path)
    with pytest.raises(OSError, match="simulated"):
        write_truth({"k": 2.0}, path)
    monkeypatch.undo()

    assert path.read_bytes() == old_log
    assert truth.read_bytes() == old_truth
    assert read_log(path) == small_log(5)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([path.name, truth.name])


# ----------------------------------------------------------------------------------------------------------
# Registry and docs
# ----------------------------------------------------------------------------------------------------------

def test_registry_patterns():
    assert column_spec("time").unit == "s"
    assert column_spec("q_motor_12").name == "q_motor_<i>"
    assert column_spec("q_motor_ref_3").name == "q_motor_ref_<i>"
    assert column_spec("torque_motor_cmd_1").name == "torque_motor_cmd_<i>"
    assert column_spec("torque_motor_1").name == "torque_motor_<i>"
    assert column_spec("torque_joint_ext_2").unit == "N·m"
    for bad in ("q_motor_0", "q_motor_01", "q_motor_", "q_motor", "Time", "time_1", "force_cmd_1", "q_motor_1 "):
        assert column_spec(bad) is None, bad
    # every name matches exactly one entry
    for spec in COLUMNS:
        example = spec.base + "7" if spec.indexed else spec.name
        assert sum(bool(s.pattern.fullmatch(example)) for s in COLUMNS) == 1, example


def test_docs_list_every_column_and_meta_key():
    text = DOCS.read_text(encoding="utf-8")
    for spec in COLUMNS:
        assert f"`{spec.name}`" in text, spec.name
        row = next(line for line in text.splitlines() if line.startswith(f"| `{spec.name}`"))
        assert f"| {spec.unit} |" in row, (spec.name, row)
    for key in META_KEYS:
        assert f"`{key}`" in text, key
    assert ".truth.json" in text


def test_to_pandas_keeps_values_order_and_units_in_attrs():
    """Log.to_pandas (issue 31, item 3): the same float64 values in log order; units in df.attrs (a registry unit,
    a linear axis' m and a generic column's declared unit), meta kept, and a copy (changing the frame leaves the
    log)."""
    pd = pytest.importorskip("pandas")
    t = np.arange(5) / 100.0
    log = make_log({"time": t, "q_motor_1": t * 2, "torque_motor_1": t * 3, "input_1": t + 1}, device="x",
                   rate_hz=100.0, seed=None, experiment="e", units={"q_motor_1": "m", "torque_motor_1": "N"},
                   signals={"input_1": {"name": "voltage", "unit": "V"}})
    df = log.to_pandas()
    assert list(df.columns) == ["time", "q_motor_1", "torque_motor_1", "input_1"]
    assert all(df[c].dtype == np.float64 for c in df.columns)
    np.testing.assert_array_equal(df["q_motor_1"].to_numpy(), t * 2)
    assert df.attrs["units"] == {"time": "s", "q_motor_1": "m", "torque_motor_1": "N", "input_1": "V"}
    assert df.attrs["signals"]["input_1"] == "voltage" and df.attrs["meta"]["device"] == "x"
    df.iloc[0, 1] = 99.0
    assert log["q_motor_1"][0] == 0.0
    dfi = log.to_pandas(time_index=True)
    assert dfi.index.name == "time" and list(dfi.columns) == ["q_motor_1", "torque_motor_1", "input_1"]
    assert isinstance(dfi.index, pd.Index) and dfi.attrs["units"]["time"] == "s"
