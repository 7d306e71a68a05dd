"""The `tendyn` command: JSON contracts of `routing show` and `simulate`, errors, files written."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.io.logs import read_log, read_truth


def run_cli(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_routing_show_json_keys(capsys):
    code, out, _ = run_cli(capsys, "routing", "show", "lexos", "--json")
    assert code == 0
    doc = json.loads(out)
    for key in ("joint_from_motor_position", "motor_from_joint_position", "motor_from_joint_torque",
                "joint_from_motor_torque", "K"):
        assert np.asarray(doc[key]).shape == (4, 4), key
    K = np.asarray(doc["K"])
    np.testing.assert_allclose(np.asarray(doc["joint_from_motor_position"]) @ np.asarray(doc["motor_from_joint_position"]),
                               np.eye(4), atol=1e-12)
    assert K[0, 0] == pytest.approx(0.32)
    assert doc["routing"][3]["radius_at_joint_m"][:3] == pytest.approx([0.015, -0.015, 0.015])


def test_routing_show_text(capsys):
    code, out, _ = run_cli(capsys, "routing", "show", "lexos")
    assert code == 0 and "motor_from_joint_torque" in out and "L-EXOS" in out


def test_bad_device_is_one_clear_error(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("schema = 1\n[device]\nname = 3\n")
    code, out, err = run_cli(capsys, "routing", "show", str(bad))
    assert code == 2 and out == ""
    assert "bad.toml" in err and "kinematics" in err and "missing" in err
    code, _, err = run_cli(capsys, "routing", "show", "no_such_twin")
    assert code == 2 and "lexos" in err


def test_simulate_writes_log_and_truth_beside(capsys, tmp_path):
    out_path = tmp_path / "bl.parquet"
    code, out, _ = run_cli(capsys, "simulate", "lexos", "blocked-link", "--joint", "2", "--torque", "0.1",
                           "--period", "0.5", "--cycles", "1", "--out", str(out_path), "--json", "--quiet")
    assert code == 0
    summary = json.loads(out)
    assert summary["logs"][0]["log"] == str(out_path)
    log = read_log(out_path)
    assert log.meta["experiment"] == "blocked_link" and log.meta["device"] == "L-EXOS"
    assert log.n_samples == 500 and "torque_motor_2" in log and "q_joint_1" not in log
    truth = read_truth(out_path)
    assert "routing" in truth
    raw = out_path.read_bytes()
    assert b"tau0" not in raw                        # the truth is beside the log, never inside
    q = log.stack("q_motor_")
    assert np.all(np.ptp(q, axis=0) == 0)            # L-EXOS cables are inextensible: blocked links, still motors
    assert np.ptp(log["torque_motor_cmd_2"]) == pytest.approx(0.2, rel=0.05)


def test_simulate_rejects_bad_output_suffix(capsys, tmp_path):
    code, _, err = run_cli(capsys, "simulate", "lexos", "blocked-link", "--cycles", "1", "--period", "0.2",
                           "--out", str(tmp_path / "x.txt"), "--quiet")
    assert code == 2 and ".parquet or .csv" in err


def test_console_script_runs():
    res = subprocess.run([sys.executable, "-m", "tendyn.cli", "routing", "show", "lexos", "--json"],
                         capture_output=True, text=True, check=True)
    assert json.loads(res.stdout)["n"] == 4


def test_demo_on_the_tendon_bench_shows_the_peak_moving(capsys, tmp_path):
    """C22 through the demo: the open-loop peak rises with input amplitude, inside 12–35 Hz."""
    code, out, _ = run_cli(capsys, "demo", "mcgill_bench", "--out", str(tmp_path), "--json")
    assert code == 0
    doc = json.loads(out)
    peaks = [f for _, f in sorted((float(a), f) for a, f in doc["peak_hz"].items())]
    assert peaks == sorted(peaks) and peaks[-1] - peaks[0] >= 12 and 12 <= peaks[0] and peaks[-1] <= 35
    assert (tmp_path / "bench_frf_amplitudes.png").stat().st_size > 10_000


def test_simulate_on_the_tendon_bench(capsys, tmp_path):
    out_path = tmp_path / "slow.parquet"
    code, out, _ = run_cli(capsys, "simulate", "mcgill_bench", "low-speed-loop", "--torque", "0.31",
                           "--cycles", "1", "--out", str(out_path), "--json", "--quiet")
    assert code == 0
    log = read_log(out_path)
    assert list(log.columns) == ["time", "force_cmd", "force_tendon", "x_tendon"]
    assert log.units["force_tendon"] == "N" and log.meta["rate_hz"] == 1000.0
    # the dead-band: a 0.31 N input at 0.2 Hz gives a much smaller, clipped output (C21, C24)
    assert np.ptp(log["force_tendon"]) < 0.8 * np.ptp(log["force_cmd"])
    assert "friction_c0" in json.dumps(read_truth(out_path))
    code, _, err = run_cli(capsys, "simulate", "mcgill_bench", "exciting", "--out", str(tmp_path / "x.parquet"))
    assert code == 2 and "tendon bench" in err


def test_routing_show_and_demo_on_capstan_and_bench_devices(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "routing", "show", "cea_branch", "--json")
    assert code == 0
    doc = json.loads(out)
    np.testing.assert_allclose(doc["motor_from_joint_position"], np.diag([20.0] * 3))
    code, _, err = run_cli(capsys, "routing", "show", "mcgill_bench")
    assert code == 2 and "no routing" in err
    code, out, _ = run_cli(capsys, "demo", "cea_branch", "--out", str(tmp_path), "--json")
    assert code == 0
    slopes = json.loads(out)["stiffness_motor_Nm_rad"]
    assert all(k == pytest.approx(2.0, rel=0.05) for k in slopes.values())   # K_T, S2 Table 2


def test_main_reuses_its_parser_and_no_default_can_carry_a_value_between_calls(tmp_path, capsys, monkeypatch):
    """main() builds its parser once per process (tendyn.cli._main_parser). What could carry a value from one call
    to the next is a default object a command changes in place (a list default is the same object in every call):
    every option's default is immutable (None, a string, a number, a tuple). A second call of the same parser
    starts from the defaults, not from the first call's options."""
    import argparse

    import tendyn.cli as cli
    import tendyn.sim.catalogue as catalogue

    def actions(parser, words=()):
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sub in a.choices.items():
                    yield from actions(sub, words + (name,))
            else:
                yield words, a

    mutable = sorted({(" ".join(w), a.dest) for w, a in actions(cli.build_parser())
                      if not isinstance(a.default, (type(None), str, int, float, bool, tuple, frozenset))})
    assert mutable == [], mutable

    seen = []

    def record(device, experiment, o, progress=None):
        seen.append(dict(o))
        raise KeyboardInterrupt          # stop before the run: exit 130

    monkeypatch.setattr(catalogue, "run", record)
    out = str(tmp_path / "x.parquet")
    assert cli.main(["simulate", "lexos", "constant-velocity", "--speeds", "1,2", "--seed", "5", "--out", out,
                     "--quiet"]) == 130
    parser = cli._main_parser()
    assert cli.main(["simulate", "lexos", "constant-velocity", "--out", out, "--quiet"]) == 130
    assert cli._main_parser() is parser                  # the same parser object served the second call
    first, second = seen
    assert list(first["speeds"]) == [1.0, 2.0] and first["seed"] == 5
    assert second["speeds"] is None or list(second["speeds"]) != [1.0, 2.0], second
    assert second["seed"] != 5, second
    assert cli.main(["simulate", "lexos", "constant-velocity", "--speeds", "abc", "--out", out]) == 2
    assert "--speeds" in capsys.readouterr().err
