"""Guards of issue 22's leftovers: files of another device refused unless --force (identify --stream,
identify-friction, decompose), memory checked before `plan` and `sweep` build anything, JSON bounded in size
and digits, the history database never created by a refused or read-only command, errors about imported data
naming the RAW files, and Ctrl-C: held while a set of files is put in place, exit 130 after the command returned."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.io import make_log, write_log


def _err(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


def _log(device: str, n: int = 200):
    return make_log({"time": np.arange(n) / 1000.0, **{f"q_motor_{k}": np.zeros(n) for k in range(1, 5)}},
                    device=device, rate_hz=1000.0, seed=None, experiment="exciting")


# ---- files of another device ------------------------------------------------------------------------------------

def test_identify_stream_refuses_a_log_of_another_device_unless_forced(tmp_path, capsys):
    """In memory, `identify` refused it; `--stream` read only the footer's rate and used the log without a word."""
    path = write_log(_log("CEA branch"), tmp_path / "other.parquet")
    code = main(["identify", "lexos", str(path), "--stream", "--quiet"])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "other.parquet" in err[0] and "'CEA branch'" in err[0], err
    assert "--force" in err[0]
    code = main(["identify", "lexos", str(path), "--stream", "--quiet", "--force"])
    err = _err(capsys)
    assert code == 2 and "needs torque_motor_1" in err[-1], err    # past the device check: the log lacks torques


def test_identify_friction_refuses_a_log_of_another_device_unless_forced(tmp_path, capsys):
    path = write_log(_log("CEA branch"), tmp_path / "other.csv")
    out = tmp_path / "friction.json"
    code = main(["identify-friction", "lexos", str(path), "--out", str(out)])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "'CEA branch'" in err[0] and "--force" in err[0], err
    code = main(["identify-friction", "lexos", str(path), "--out", str(out), "--force"])
    err = _err(capsys)
    assert code == 2 and "no constant-velocity log for transmission 2" in err[-1], err   # past the device check
    assert not out.exists()


def test_decompose_refuses_a_friction_file_of_another_device_unless_forced(tmp_path, capsys):
    from tendyn.devices.generate import write_cable_device

    dev = write_cable_device(tmp_path, 4, name="gen4")            # as many transmissions as the L-EXOS
    doc = {"format": "tendyn.friction/1", "device": "L-EXOS", "n_transmissions": 4,
           "coulomb_motor": [0.01] * 4, "viscous_motor": [0.001] * 4,
           "fits": [{"transmission": t, "coulomb_motor": 0.01, "viscous_motor": 0.001, "coulomb_motor_std": 1e-4,
                     "viscous_motor_std": 1e-5} for t in range(1, 5)]}
    path = tmp_path / "friction.json"
    path.write_text(json.dumps(doc))
    code = main(["decompose", str(dev), str(path)])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "'L-EXOS'" in err[0] and "--force" in err[0], err
    assert main(["decompose", str(dev), str(path), "--force"]) == 0
    capsys.readouterr()
    assert main(["decompose", "lexos", str(path)]) == 0                # its own device: no --force needed
    capsys.readouterr()
    other = write_cable_device(tmp_path, 3, name="gen3")           # another transmission count: refused even so
    code = main(["decompose", str(other), str(path), "--force"])
    err = _err(capsys)
    assert code == 2 and "n_transmissions" in err[0], err


# ---- memory before the work --------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["plan", "prbs", "--amplitude", "1", "--duration", "1e5", "--rate", "1e6", "--name", "v", "--unit", "V"],
    ["plan", "multisine", "--amplitude", "1", "--duration", "10", "--band", "0,4e5", "--period", "1e4",
     "--rate", "1e6", "--name", "v", "--unit", "V"],
    ["plan", "stepped-sine", "--amplitude", "1", "--frequencies", "0.001,0.002", "--settle", "1e4",
     "--cycles", "100000", "--rate", "1e6", "--name", "v", "--unit", "V"],
    ["plan", "constant-velocity", "lexos", "--transmission", "1", "--accel", "1e-3", "--rate", "1e6"],
])
def test_plan_refuses_what_cannot_fit_in_memory_before_building_it(tmp_path, capsys, argv):
    """`plan --accel 1e-6` ended in a MemoryError after minutes; every plan kind now estimates first."""
    t0 = time.perf_counter()
    code = main([*argv, "--out", str(tmp_path / "ref.csv")])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "of memory" in err[0], err
    assert time.perf_counter() - t0 < 10 and list(tmp_path.iterdir()) == []


def test_sweep_refuses_what_cannot_fit_in_memory_before_starting_workers(tmp_path, capsys, monkeypatch):
    from tendyn.sim import limits

    monkeypatch.setattr(limits, "memory_available", lambda: 500e6)   # a small machine: 2 workers do not fit
    code = main(["sweep", "mcgill_bench", "--param", "mass_motor=0.01:0.02:2", "--workers", "2",
                 "--out", str(tmp_path / "s.parquet"), "--quiet"])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "of memory" in err[0] and "--workers" in err[0], err
    assert list(tmp_path.iterdir()) == []


def test_zwidth_workers_are_bounded_like_sweep(tmp_path, capsys):
    code = main(["zwidth", "lexos", "--workers", "100000", "--out", str(tmp_path / "z.parquet")])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and err[0].startswith("tendyn: error: --workers"), err


# ---- JSON bounded ------------------------------------------------------------------------------------------------

def _friction_text(coulomb: str) -> str:
    return ('{"format": "tendyn.friction/1", "device": "L-EXOS", "n_transmissions": 4, "coulomb_motor": [' + coulomb
            + ', 0.01, 0.01, 0.01], "viscous_motor": [0.001, 0.001, 0.001, 0.001], "fits": []}')


def test_json_larger_than_the_limit_is_refused_before_it_is_read(tmp_path, capsys, monkeypatch):
    import tendyn.io.files as files

    path = tmp_path / "friction.json"
    path.write_text(_friction_text("0.01"))
    monkeypatch.setattr(files, "MAX_JSON_BYTES", 64)
    code = main(["decompose", "lexos", str(path)])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "friction.json" in err[0] and "larger than" in err[0], err


def test_json_with_a_huge_integer_is_a_bad_file_not_a_crash(tmp_path, capsys):
    path = tmp_path / "friction.json"
    path.write_text(_friction_text("9" * 5000))      # past the interpreter's 4300-digit int conversion limit
    code = main(["decompose", "lexos", str(path)])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "friction.json" in err[0], err


# ---- the history database ----------------------------------------------------------------------------------------

def test_no_history_database_is_created_by_a_refused_record_or_a_read(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    bad = tmp_path / "bad.csv"
    bad.write_text("not a log\n")
    assert main(["identify", "lexos", str(bad), "--record", "--quiet"]) == 2
    assert main(["history", "lexos"]) == 0
    capsys.readouterr()
    assert not (tmp_path / "xdg").exists()
    db = tmp_path / "h.sqlite"
    db.write_bytes(b"garbage, not sqlite" * 10)
    code = main(["identify", "lexos", str(bad), "--record", "--db", str(db), "--quiet"])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "--db" in err[0] and "not a tendyn history database" in err[0], err


# ---- errors name the files ---------------------------------------------------------------------------------------

def test_an_error_in_imported_data_names_the_raw_file_not_memory(tmp_path, capsys):
    raw = tmp_path / "raw.csv"
    raw.write_text("a\n1\n1e308\n")                  # finite in the file, inf after the map's scale
    mp = tmp_path / "map.toml"
    mp.write_text('schema = 1\n[log]\ndevice = "x"\nexperiment = "e"\nrate_hz = 100.0\n'
                  '[[signals]]\ncolumn = "a"\nsignal = "q_motor_1"\nscale = 10.0\n')
    code = main(["log", "import", str(raw), "--map", str(mp), "--out", str(tmp_path / "log.csv")])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and "raw.csv" in err[0] and "map.toml" in err[0], err
    assert "<memory>" not in err[0]


@pytest.mark.parametrize("argv", [["simulate", "a" * 300, "exciting", "--out", "{tmp}/x.csv"],
                                  ["decompose", "lexos", "b" * 300],
                                  ["plan", "prbs", "--amplitude", "1", "--duration", "1", "--name", "v", "--unit", "V",
                                   "--out", "{tmp}/" + "c" * 300 + ".csv"]])
def test_a_path_longer_than_the_file_system_allows_is_an_input_error(tmp_path, capsys, argv):
    """ENAMETOOLONG from an existence check was an internal error (exit 3)."""
    code = main([a.replace("{tmp}", str(tmp_path)) for a in argv])
    err = _err(capsys)
    assert code == 2 and len(err) == 1 and err[0].startswith("tendyn: error: ") and "too long" in err[0], err
    assert list(tmp_path.iterdir()) == []


# ---- Ctrl-C --------------------------------------------------------------------------------------------------

def test_a_ctrl_c_while_files_are_put_in_place_is_held_until_the_set_is_whole(sigint_default):
    from tendyn.io.files import interrupts_deferred

    done = []
    with pytest.raises(KeyboardInterrupt):
        with interrupts_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)                     # a handler would have run by now
            done.append("second file")
    assert done == ["second file"]


def test_simulate_interrupted_while_writing_writes_every_pair_then_exits_130(tmp_path, capsys, monkeypatch,
                                                                            sigint_default):
    """A stepped sine writes one log and truth per frequency: a Ctrl-C at the first write leaves all of them."""
    import tendyn.cli as cli

    real = cli._write_run
    calls = []

    def write_run(log, truth, path):
        if not calls:
            os.kill(os.getpid(), signal.SIGINT)
        calls.append(path)
        return real(log, truth, path)

    monkeypatch.setattr(cli, "_write_run", write_run)
    out = tmp_path / "run.csv"
    code = main(["simulate", "mcgill_bench", "stepped-sine", "--freqs", "20,40", "--cycles", "2", "--rate", "1000",
                 "--log-rate", "1000", "--out", str(out), "--quiet"])
    err = _err(capsys)
    assert code == 130 and err[-1] == "tendyn: interrupted", err
    from tendyn.io.logs import read_run

    for k in (1, 2):
        read_run(tmp_path / f"run_0{k}.csv")       # each pair whole and of one run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run_01.csv", "run_01.truth.json", "run_02.csv",
                                                          "run_02.truth.json"]


def _python_as_tendyn(code: str, sigint) -> subprocess.CompletedProcess:
    """``python -c code`` (a script that ends in tendyn's ``main()``) started with SIGINT's action set to ``sigint``
    (SIG_IGN: a background job's inheritance; SIG_DFL: a terminal's)."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, sigint))


def test_a_process_started_with_ctrl_c_ignored_keeps_ignoring_it():
    """A background job inherits SIGINT ignored (its shell's `trap '' INT`, or `&` without job control): tendyn
    honours that ignore while files are put in place and after the command returned — exit 0, no 'interrupted'."""
    code = ("import atexit, os, signal, sys, time\n"
            "from tendyn.io.files import interrupts_deferred\n"
            "with interrupts_deferred():\n"
            "    os.kill(os.getpid(), signal.SIGINT)\n"
            "    time.sleep(0.05)\n"
            "atexit.register(lambda: (os.kill(os.getpid(), signal.SIGINT), time.sleep(0.2)))\n"
            "sys.argv = ['tendyn', 'config', '--cflags']\n"
            "from tendyn.cli import main\n"
            "sys.exit(main())\n")
    res = _python_as_tendyn(code, signal.SIG_IGN)
    assert res.returncode == 0 and "interrupted" not in res.stderr, (res.returncode, res.stderr)
    assert res.stdout.strip()


def test_a_ctrl_c_after_the_command_returned_is_exit_130_not_death_by_signal(tmp_path):
    """The process's own command line: a Ctrl-C during the exit (here: from an exit handler) ends it with
    status 130 and the line, not with the interpreter's 'Exception ignored' or signal 2."""
    code = ("import atexit, os, signal, sys, time\n"
            "atexit.register(lambda: (os.kill(os.getpid(), signal.SIGINT), time.sleep(5)))\n"
            "sys.argv = ['tendyn', 'config', '--cflags']\n"
            "from tendyn.cli import main\n"
            "sys.exit(main())\n")
    res = _python_as_tendyn(code, signal.SIG_DFL)
    assert res.returncode == 130, (res.returncode, res.stderr)
    assert res.stderr.strip().splitlines()[-1] == "tendyn: interrupted" and "Traceback" not in res.stderr
    assert res.stdout.strip()                      # the command's output was flushed before


def test_an_exit_handler_failing_after_a_ctrl_c_prints_no_traceback():
    """A Ctrl-C while a local Dask cluster started left Dask's exit handler to close workers that never started:
    it raised (AssertionError: Status.init) and the interpreter printed the traceback after 'tendyn: interrupted'.
    After an interrupt the exit handlers still run (the worker processes end), their failures unreported: status
    130 and the one line. Deterministic here: the command is interrupted by the test and an exit handler raises."""
    code = ("import atexit, sys\n"
            "import tendyn.cli as cli\n"
            "ran = []\n"
            "def failing():\n"
            "    ran.append(1)\n"
            "    raise AssertionError('Status.init')\n"
            "atexit.register(lambda: print('handler ran' if ran else 'handler did not run'))\n"
            "atexit.register(failing)\n"
            "def interrupted(args):\n"
            "    raise KeyboardInterrupt\n"
            "cli.cmd_demo = interrupted                 # the parser, built in main(), binds it\n"
            "sys.argv = ['tendyn', 'demo', 'lexos']\n"
            "sys.exit(cli.main())\n")
    res = _python_as_tendyn(code, signal.SIG_DFL)
    assert res.returncode == 130, (res.returncode, res.stderr)
    assert res.stderr.strip() == "tendyn: interrupted", res.stderr
    assert res.stdout.strip() == "handler ran", res.stdout        # the exit handlers did run
