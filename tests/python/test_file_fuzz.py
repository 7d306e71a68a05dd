"""Seeded corruptions of every kind of input file a command reads (issue 22, item 5, on files): a RAW CSV and its
import map (`log import`), a log (`identify`), FRICTION.json (`decompose`), PARAMS.json (`maps`). Each corrupted
file must give exit 0, 1 or 2 — never an internal error (3) — with one line on stderr for 2 and nothing written
unless the command succeeded. A bounded budget runs in `make test`; `-m slow` runs ten times more."""

import json
import os

import numpy as np
import pytest

from tendyn.cli import main

INSERTS = [b"nan", b"1e400", b"-1", b"[", b"{", b'"', b"\x00", b"\xff\xfe", b"9" * 400, b"[" * 5000, b"1_000",
           b"#", b"\n", b",", b";", b"\r", b"true", b"null", b"\\u0000", b"0x10"]


def _corrupt(data: bytes, rng) -> bytes:
    """One to four edits: a random byte, a deleted span, an inserted token, or a truncation."""
    b = bytearray(data)
    for _ in range(int(rng.integers(1, 5))):
        if not b:
            break
        at = int(rng.integers(len(b)))
        kind = rng.integers(4)
        if kind == 0:
            b[at] = int(rng.integers(256))
        elif kind == 1:
            del b[at:at + int(rng.integers(1, 20))]
        elif kind == 2:
            b[at:at] = INSERTS[int(rng.integers(len(INSERTS)))]
        else:
            del b[at:]
    return bytes(b)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Good files of each kind, from the commands themselves."""
    from tendyn.analysis.operational import true_params
    from tendyn.device import load_device
    from tendyn.devices import bundled

    d = tmp_path_factory.mktemp("good")
    (d / "raw.csv").write_text("t,a,b\n" + "".join(f"{k / 100},{np.sin(k / 7):.6f},{k % 5}\n" for k in range(60)))
    (d / "map.toml").write_text('schema = 1\n[log]\ndevice = "L-EXOS"\nexperiment = "e"\n'
                                '[[signals]]\ncolumn = "t"\nsignal = "time"\n'
                                '[[signals]]\ncolumn = "a"\nsignal = "q_motor_1"\n'
                                '[[signals]]\ncolumn = "b"\nsignal = "torque_motor_1"\nscale = 0.5\n')
    assert main(["log", "import", str(d / "raw.csv"), "--map", str(d / "map.toml"), "--out", str(d / "log.csv")]) == 0
    n = 4
    fits = [{"transmission": t, "coulomb_motor": 0.01 * t, "viscous_motor": 0.001 * t, "coulomb_motor_std": 1e-4,
             "viscous_motor_std": 1e-5} for t in range(1, n + 1)]
    (d / "friction.json").write_text(json.dumps({
        "format": "tendyn.friction/1", "device": "L-EXOS", "n_transmissions": n,
        "coulomb_motor": [f["coulomb_motor"] for f in fits], "viscous_motor": [f["viscous_motor"] for f in fits],
        "fits": fits}))
    dev = load_device(bundled("cea_branch"))
    (d / "params.json").write_text(json.dumps({"device": dev.name, "params": true_params(dev)}))
    assert main(["decompose", "lexos", str(d / "friction.json")]) == 0
    return d


# (argv with {file} for the corrupted file, {good}/NAME for the good ones and {out} for an output; the file)
COMMANDS = [
    (["log", "import", "{file}", "--map", "{good}/map.toml", "--out", "{out}/log.parquet"], "raw.csv"),
    (["log", "import", "{good}/raw.csv", "--map", "{file}", "--out", "{out}/log.parquet"], "map.toml"),
    (["frf", "{file}", "--input", "torque_motor_1", "--output", "q_motor_1", "--out", "{out}/frf.json"], "log.csv"),
    (["decompose", "lexos", "{file}", "--json"], "friction.json"),
    (["maps", "lexos", "--friction", "{file}", "--points", "2", "--report", "{out}/maps"], "friction.json"),
    (["maps", "cea_branch", "{file}", "--points", "3", "--json"], "params.json"),
]


def _run(files, tmp_path, capsys, cases: int, seed: int):
    rng = np.random.default_rng(seed)
    counts = {0: 0, 1: 0, 2: 0}
    for k in range(cases):
        argv, name = COMMANDS[k % len(COMMANDS)]
        case = tmp_path / f"case{k}"
        out = case / "out"
        out.mkdir(parents=True)
        bad = case / name
        bad.write_bytes(_corrupt((files / name).read_bytes(), rng))
        args = [a.replace("{file}", str(bad)).replace("{good}", str(files)).replace("{out}", str(out)) for a in argv]
        code = main(args)
        cap = capsys.readouterr()
        assert code in counts, (args, bad.read_bytes()[:300], cap.err)
        counts[code] += 1
        if code == 2:
            lines = cap.err.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("tendyn: error: "), (args, cap.err)
        if code != 0:
            assert os.listdir(out) == [], (args, os.listdir(out))
    return counts


def test_corrupted_input_files_never_crash(files, tmp_path, capsys):
    counts = _run(files, tmp_path, capsys, cases=240, seed=20261202)
    assert counts[2] > 60 and counts[0] > 10, counts        # both outcomes are exercised


@pytest.mark.slow
def test_corrupted_input_files_never_crash_long(files, tmp_path, capsys):
    """Ten times the budget (~40 s); runs only when asked: `pytest -m slow tests/python/test_file_fuzz.py`."""
    _run(files, tmp_path, capsys, cases=2400, seed=7)
