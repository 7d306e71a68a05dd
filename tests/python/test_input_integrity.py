"""Nothing silently wrong (issue 22): bad or corrupt input files are refused with one line naming the file and
what is wrong, never read as other data. Each case here was once read without a word (exit 0)."""

from __future__ import annotations

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.io import LogError, make_log, read_log, write_log
from tendyn.io.importer import import_logs

MAP = ('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\n{log}'
       '[[signals]]\n{file}column = "{col}"\nsignal = "{sig}"\n')


def _map(tmp_path, log="rate_hz = 100.0\n", col="a", sig="q_motor_1", file=""):
    mp = tmp_path / "map.toml"
    mp.write_text(MAP.format(log=log, col=col, sig=sig, file=file))
    return mp


def test_two_raw_files_with_the_same_name_are_refused_not_merged(tmp_path):
    """`log import a/raw.csv b/raw.csv` kept only b's data (the map keys files by base name)."""
    for d, v in (("a", "1"), ("b", "2")):
        (tmp_path / d).mkdir()
        (tmp_path / d / "raw.csv").write_text(f"a\n{v}\n{v}\n")
    mp = _map(tmp_path, file='file = "raw.csv"\n')
    with pytest.raises(LogError, match=r"two RAW files are named raw.csv"):
        import_logs([tmp_path / "a" / "raw.csv", tmp_path / "b" / "raw.csv"], mp)


def test_a_rate_that_contradicts_the_time_column_is_refused_naming_both(tmp_path):
    """rate_hz = 5000 over a 1 kHz time column wrote a 5 kHz log."""
    raw = tmp_path / "raw.csv"
    raw.write_text("t,a\n" + "".join(f"{k / 1000},{k}\n" for k in range(20)))
    mp = tmp_path / "map.toml"
    sig = '[[signals]]\ncolumn = "t"\nsignal = "time"\n[[signals]]\ncolumn = "a"\nsignal = "q_motor_1"\n'
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 5000.0\n' + sig)
    with pytest.raises(LogError, match=r"log.rate_hz: 5000 Hz, but the signal mapped to time is sampled at 1000 Hz"):
        import_logs([raw], mp)
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 1000.0\n' + sig)
    assert import_logs([raw], mp).meta["rate_hz"] == 1000.0


def test_a_log_whose_rate_contradicts_its_time_column_is_refused_on_read(tmp_path):
    good = make_log({"time": np.arange(50) / 1000.0, "q_motor_1": np.zeros(50)}, device="x", rate_hz=1000.0,
                    seed=None, experiment="e")
    path = write_log(good, tmp_path / "g.csv")
    path.write_text(path.read_text().replace('"rate_hz": 1000.0', '"rate_hz": 5000.0'))
    with pytest.raises(LogError, match=r"meta.rate_hz: 5000 Hz, but the time column is sampled at 1000 Hz"):
        read_log(path)


@pytest.mark.parametrize("cell", ["1_000", "1_0.5"])
def test_an_underscore_in_a_number_is_refused(tmp_path, cell):
    """float('1_000') is 1000 in Python; no lab file means that."""
    raw = tmp_path / "raw.csv"
    raw.write_text(f"a\n1\n{cell}\n")
    with pytest.raises(LogError, match=r"not a number"):
        import_logs([raw], _map(tmp_path))
    log = make_log({"time": np.arange(3) / 100.0, "q_motor_1": np.zeros(3)}, device="x", rate_hz=100.0, seed=None,
                   experiment="e")
    path = write_log(log, tmp_path / "l.csv")
    text = path.read_text().splitlines()
    text[-1] = text[-1].split(",")[0] + "," + cell
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(LogError, match=r"row 2 \(line 5\): cannot read '" + cell + "'"):
        read_log(path)


def test_a_comment_row_among_the_data_is_refused_not_dropped(tmp_path):
    """Without a time column a dropped row shifted every later sample by one period."""
    raw = tmp_path / "raw.csv"
    raw.write_text("# exported by the lab\na\n1\n#2\n3\n")
    with pytest.raises(LogError, match=r"raw.csv: line 4: a comment row among the data rows"):
        import_logs([raw], _map(tmp_path))
    raw.write_text("# exported by the lab\na\n1\n2\n3\n")     # leading comments stay allowed
    assert list(import_logs([raw], _map(tmp_path))["q_motor_1"]) == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("content, words", [
    ("a\n1\n\xe9\n".encode("latin-1"), r"not UTF-8 text \(byte 0xe9"),
    (b"a\n1\n2\x003\n", "a NUL byte at line 3"),
])
def test_a_binary_or_latin1_raw_file_is_one_line(tmp_path, content, words):
    raw = tmp_path / "raw.csv"
    raw.write_bytes(content)
    with pytest.raises(LogError, match=words):
        import_logs([raw], _map(tmp_path))


@pytest.mark.parametrize("delimiter", ["", ";;", '"'])
def test_a_delimiter_that_is_not_one_character_is_refused(tmp_path, delimiter):
    raw = tmp_path / "raw.csv"
    raw.write_text("a\n1\n2\n")
    with pytest.raises(LogError, match=r"log.delimiter: must be one character"):
        import_logs([raw], _map(tmp_path, log=f'rate_hz = 100.0\ndelimiter = "{delimiter}"\n'.replace('"""', "'\"'")))


def test_a_one_row_raw_file_with_a_time_column_is_refused_clearly(tmp_path):
    raw = tmp_path / "raw.csv"
    raw.write_text("t\n0.5\n")
    with pytest.raises(LogError, match=r"one data row"):
        import_logs([raw], _map(tmp_path, log="", col="t", sig="time"))


def test_log_import_never_overwrites_a_raw_file(tmp_path, capsys):
    raw = tmp_path / "raw.csv"
    raw.write_text("a\n1\n2\n")
    before = raw.read_bytes()
    code = main(["log", "import", str(raw), "--map", str(_map(tmp_path)), "--out", str(raw)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--out" in err[0] and "raw.csv" in err[0], err
    assert raw.read_bytes() == before


def test_a_corrupted_parquet_log_is_refused_never_read_as_data(tmp_path):
    """2 000 corrupted bytes were read as data (values up to 1e136) and identified: logs are written with page
    checksums and verified on read. 30 seeded corruptions of the data pages: every one refused."""
    n = 20000
    rng = np.random.default_rng(0)
    log = make_log({"time": np.arange(n) / 1000.0, "q_motor_1": rng.standard_normal(n),
                    "torque_motor_1": rng.standard_normal(n)}, device="x", rate_hz=1000.0, seed=None, experiment="e")
    good = write_log(log, tmp_path / "good.parquet").read_bytes()
    bad = tmp_path / "bad.parquet"
    for trial in range(30):
        r = np.random.default_rng(trial)
        data = bytearray(good)
        start = int(r.integers(8, len(data) // 2))
        data[start:start + 2000] = r.integers(0, 256, 2000, dtype=np.uint8).tobytes()
        bad.write_bytes(bytes(data))
        with pytest.raises(LogError, match=r"bad.parquet: not a readable Parquet file"):
            read_log(bad)


def _params_doc(name="cea_branch", **changes):
    """The document `tendyn identify --json` would give with the device file's own values (its prior)."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident import IdentModel

    dev = load_device(bundled(name))
    model = IdentModel(dev)
    values = model.base.combination @ model.prior()
    params = [{"name": n, "value": float(v), "stderr": 0.0, "expression": model.base.expression(i, model.standard_names)}
              for i, (n, v) in enumerate(zip(model.base.names, values))]
    return dict({"device": dev.name, "params": params}, **changes)


def _maps(tmp_path, capsys, doc, *extra):
    import json

    path = tmp_path / "params.json"
    path.write_text(json.dumps(doc))
    code = main(["maps", "cea_branch", str(path), "--points", "3", "--json", *extra])
    cap = capsys.readouterr()
    return code, cap.err.strip().splitlines(), cap.out


def test_a_params_file_missing_a_base_parameter_is_refused_not_zeroed(tmp_path, capsys):
    """A params.json without ZZ1R gave 2.67 kg instead of 0.74 kg (ZZ1R taken as 0)."""
    doc = _params_doc()
    doc["params"] = [p for p in doc["params"] if p["name"] != "ZZ1R"]
    code, err, out = _maps(tmp_path, capsys, doc)
    assert code == 2 and len(err) == 1 and "params.json: params: missing base parameter(s) ZZ1R" in err[0], err
    doc = _params_doc()
    doc["params"] = [p for p in doc["params"] if p["name"] != "FV1"]
    assert _maps(tmp_path, capsys, doc)[0] == 2
    doc["omitted"] = ["FV1"]                        # left out on purpose (identify --parameters / --essential)
    assert _maps(tmp_path, capsys, doc)[0] == 0


def test_an_identified_model_of_an_essential_fit_keeps_what_it_left_out():
    """IdentifiedModel of a document with ``omitted`` writes it back (to_dict): the document it gives is read again,
    also through a calibrated device given the model in memory, as maps reads it (to_dict used to drop
    ``omitted``: "missing base parameter(s) FV1")."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident.calibrated import calibrate
    from tendyn.ident.identified import IdentifiedModel

    dev = load_device(bundled("cea_branch"))
    doc = _params_doc()
    doc["params"] = [p for p in doc["params"] if p["name"] != "FV1"]
    doc["omitted"] = ["FV1"]
    model = IdentifiedModel.from_document(doc, device=dev)
    again = IdentifiedModel.from_document(model.to_dict(), device=dev)
    assert model.omitted == again.omitted == ["FV1"]
    cal = calibrate(dev, params=model)
    assert cal.params["omitted"] == ["FV1"]
    assert IdentifiedModel.from_document(cal.params, device=dev).omitted == ["FV1"]


def test_a_params_file_of_another_device_is_refused_unless_forced(tmp_path, capsys):
    code, err, _ = _maps(tmp_path, capsys, _params_doc(device="L-EXOS"))
    assert code == 2 and len(err) == 1 and "device" in err[0] and "'L-EXOS'" in err[0] and "--force" in err[0], err
    assert _maps(tmp_path, capsys, _params_doc(device="L-EXOS"), "--force")[0] == 0


def test_identify_refuses_a_log_of_another_device_unless_forced(tmp_path, capsys):
    n = 200
    log = make_log({"time": np.arange(n) / 1000.0, **{f"q_motor_{k}": np.zeros(n) for k in range(1, 5)}},
                   device="CEA branch", rate_hz=1000.0, seed=None, experiment="exciting")
    path = write_log(log, tmp_path / "other.parquet")
    code = main(["identify", "lexos", str(path), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "other.parquet" in err[0] and "'CEA branch'" in err[0], err
    code = main(["identify", "lexos", str(path), "--quiet", "--force"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "device" not in err[-1]        # past the device check: the log lacks torques


@pytest.mark.parametrize("name", ["cea_branch", "lexos"])
@pytest.mark.parametrize("factor", [0.0, -1.0])
def test_zero_or_negative_inertias_are_refused(tmp_path, capsys, name, factor):
    """All-zero inertias gave 0 kg maps and negative ones 24.5 kg (|eigenvalues|): A(q) must be positive definite."""
    import json

    doc = _params_doc(name)
    for p in doc["params"]:
        if not p["name"].startswith(("FV", "FS", "OFFSET")):
            p["value"] *= factor
    path = tmp_path / "params.json"
    path.write_text(json.dumps(doc))
    code = main(["maps", name, str(path), "--points", "3", "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "not positive definite" in err[0] and "params.json" in err[0], err
