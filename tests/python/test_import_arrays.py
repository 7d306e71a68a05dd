"""`tendyn log import` of MATLAB (.mat v5 through scipy.io, v7.3 through h5py) and HDF5 files (issue 31, item 2):
the same import map as CSV names variables, struct fields and dataset paths; the EMPS benchmark files import
with a map and nothing else."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
scipy_io = pytest.importorskip("scipy.io")

from tendyn.cli import main  # noqa: E402
from tendyn.io import read_log  # noqa: E402
from tendyn.io.importer import import_logs  # noqa: E402
from tendyn.io.logs import LogError  # noqa: E402

SHARED = Path(os.environ.get("TENDYN_SHARED") or Path(__file__).resolve().parents[3] / "shared")
EMPS = SHARED / "external-data" / "emps"

RATE = 500.0


def signals(n=200, seed=3):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    q = rng.standard_normal((n, 3)).cumsum(axis=0) * 1e-3          # three motor angles [rad]
    tau = rng.standard_normal((n, 3))                             # three motor torques [N·m]
    return t, q, tau


MAP = """schema = 1
[log]
device = "gen3"
experiment = "exciting"
[[signals]]
column = "{t}"
signal = "time"
[[signals]]
column = "{q}"
index = 2
signal = "q_motor_2"
[[signals]]
column = "{tau}"
index = 3
signal = "torque_motor_3"
scale = 2.0
"""


def write_map(tmp_path, **names):
    mp = tmp_path / "map.toml"
    mp.write_text(MAP.format(**names))
    return mp


def write_mat73(path, variables):
    """A MATLAB v7.3 file as MATLAB writes it, made here without the code under test: an HDF5 file with a
    512-byte user block holding the MATLAB header, each array stored transposed (MATLAB is column-major)
    with its MATLAB_class attribute; a struct is a group."""
    with h5py.File(path, "w", userblock_size=512) as f:
        def put(group, name, value):
            if isinstance(value, dict):
                g = group.create_group(name)
                g.attrs["MATLAB_class"] = np.bytes_("struct")
                for k, v in value.items():
                    put(g, k, v)
                return
            arr = np.atleast_2d(np.asarray(value, dtype=np.float64))
            if arr.shape[0] == 1 and np.asarray(value).ndim == 1:
                arr = arr.T                                       # a MATLAB column vector n×1
            ds = group.create_dataset(name, data=arr.T)
            ds.attrs["MATLAB_class"] = np.bytes_("double")
        for k, v in variables.items():
            put(f, k, v)
    with open(path, "r+b") as fh:
        head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
        fh.write(head.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")


@pytest.mark.parametrize("fmt", ["v5", "v5-struct", "v7.3", "v7.3-struct", "h5"])
def test_mat_and_hdf5_import_the_named_variables(tmp_path, fmt):
    t, q, tau = signals()
    if fmt.startswith("v5"):
        f = tmp_path / "bench.mat"
        data = {"t": t, "q": q, "tau": tau}
        scipy_io.savemat(f, {"run": data} if fmt.endswith("struct") else data)
    elif fmt.startswith("v7.3"):
        f = tmp_path / "bench.mat"
        data = {"t": t, "q": q, "tau": tau}
        write_mat73(f, {"run": data} if fmt.endswith("struct") else data)
    else:
        f = tmp_path / "bench.h5"
        with h5py.File(f, "w") as h:
            h["run/t"] = t
            h["run/q"] = q                                   # rows are samples, as written
            h["run/tau"] = tau
    prefix = {"v5-struct": "run.", "v7.3-struct": "run.", "h5": "/run/"}.get(fmt, "")
    mp = write_map(tmp_path, t=prefix + "t", q=prefix + "q", tau=prefix + "tau")
    log = import_logs([f], mp)
    assert list(log.columns) == ["time", "q_motor_2", "torque_motor_3"]
    np.testing.assert_array_equal(log.time, t)
    np.testing.assert_array_equal(log["q_motor_2"], q[:, 1])           # column 2 of the samples × signals matrix
    np.testing.assert_array_equal(log["torque_motor_3"], 2.0 * tau[:, 2])
    assert log.meta["rate_hz"] == pytest.approx(RATE)


def test_cli_imports_a_mat_file(tmp_path, capsys):
    t, q, tau = signals()
    f = tmp_path / "bench.mat"
    scipy_io.savemat(f, {"t": t, "q": q, "tau": tau})
    mp = write_map(tmp_path, t="t", q="q", tau="tau")
    out = tmp_path / "log.parquet"
    assert main(["log", "import", str(f), "--map", str(mp), "--out", str(out)]) == 0
    np.testing.assert_array_equal(read_log(out)["q_motor_2"], q[:, 1])


@pytest.mark.parametrize("names, index, message", [
    (dict(t="t", q="qq", tau="tau"), None, "signals[2].column: no variable 'qq' in bench.mat (variables: "),
    (dict(t="t", q="q", tau="tau"), "index = 4", "signals[2].column: index = 4 but 'q' has 3 columns"),
    (dict(t="t", q="q", tau="tau"), "", "signals[2].column: 'q' is a 200×3 matrix in bench.mat: give index = 1..3"),
    (dict(t="gain", q="q", tau="tau"), None, "signals[1].column: 'gain' is a scalar"),
    (dict(t="label", q="q", tau="tau"), None, "signals[1].column: 'label' is not numeric"),
    (dict(t="t", q="short", tau="tau"), "", "signals[2]: bench.mat gives 10 samples, the signals before have 200"),
])
def test_mat_map_errors_are_one_line(tmp_path, capsys, names, index, message):
    t, q, tau = signals()
    f = tmp_path / "bench.mat"
    scipy_io.savemat(f, {"t": t, "q": q, "tau": tau, "gain": 3.0, "label": "bench", "short": np.arange(10.0)})
    mp = write_map(tmp_path, **names)
    if index is not None:
        mp.write_text(mp.read_text().replace("index = 2", index, 1))
    with pytest.raises(LogError) as exc:
        import_logs([f], mp)
    assert message in str(exc.value) and "\n" not in str(exc.value)
    assert main(["log", "import", str(f), "--map", str(mp), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tendyn: error:") and "\n" not in err and "Traceback" not in err


@pytest.mark.parametrize("content, message", [
    (b"not a mat file at all" * 10, "not a readable MATLAB file"),
    (b"\x89HDF\r\n\x1a\n" + b"\x00" * 40, "not a readable HDF5 file"),
])
def test_broken_files_are_refused_in_one_line(tmp_path, capsys, content, message):
    f = tmp_path / "bench.mat"
    f.write_bytes(content)
    mp = write_map(tmp_path, t="t", q="q", tau="tau")
    assert main(["log", "import", str(f), "--map", str(mp), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and err.startswith("tendyn: error:")


def test_a_column_number_or_a_bag_key_on_a_mat_file_is_refused(tmp_path):
    t, q, tau = signals()
    f = tmp_path / "bench.mat"
    scipy_io.savemat(f, {"t": t, "q": q, "tau": tau})
    mp = write_map(tmp_path, t="t", q="q", tau="tau")
    mp.write_text(mp.read_text().replace('column = "t"', "column = 1"))
    with pytest.raises(LogError, match="name the variable or dataset"):
        import_logs([f], mp)
    mp.write_text(MAP.format(t="t", q="q", tau="tau").replace('column = "tau"\nindex = 3', 'topic = "/t"\nfield = "data"'))
    with pytest.raises(LogError, match="give column, not topic"):
        import_logs([f], mp)


EMPS_MAP = """schema = 1
[log]
device = "emps"
experiment = "exciting"
[[signals]]
column = "t"
signal = "time"
[[signals]]
column = "qm"
signal = "q_motor_1"
unit = "m"
[[signals]]
column = "qg"
signal = "q_ref_1"
unit = "m"
[[signals]]
column = "vir"
signal = "torque_motor_1"
unit = "N"
scale = 35.15065            # gtau [N/V]: force = gtau · vir (the EMPS data set)
"""


@pytest.mark.skipif(not EMPS.is_dir(), reason=f"the EMPS files are not in {EMPS}")
@pytest.mark.parametrize("name", ["DATA_EMPS.mat", "DATA_EMPS_PULSES.mat"])
def test_emps_files_import_with_a_map_and_nothing_else(tmp_path, capsys, name):
    mp = tmp_path / "emps.toml"
    mp.write_text(EMPS_MAP)
    out = tmp_path / "emps.parquet"
    assert main(["log", "import", str(EMPS / name), "--map", str(mp), "--out", str(out)]) == 0
    log = read_log(out)
    raw = scipy_io.loadmat(EMPS / name)              # the oracle: scipy directly, not the importer
    assert log.n_samples == raw["t"].size == 24841
    assert log.meta["rate_hz"] == pytest.approx(1000.0, rel=1e-3)
    np.testing.assert_array_equal(log["q_motor_1"], raw["qm"].ravel())
    np.testing.assert_array_equal(log["torque_motor_1"], 35.15065 * raw["vir"].ravel())
    assert log.units["q_motor_1"] == "m" and log.units["torque_motor_1"] == "N" and log.units["q_ref_1"] == "m"
    assert raw["gtau"].item() == pytest.approx(35.15065)
