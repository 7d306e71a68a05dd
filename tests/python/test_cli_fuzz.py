"""Random bad and edge inputs to `tendyn simulate`: never a traceback, never an internal error.

The fuzz draws a device, an experiment and one to three options with values from a pool of good, bad
and strange tokens (NaN, huge, negative, empty, hex, lists where a number belongs …). The run itself is
replaced by a marker (exit 130) so that only the checks are exercised: every case must end in exit 2
with one line, or be accepted. Accepted edge cases then run for real (short runs) and must succeed.
"""

import json

import numpy as np
import pytest

import tendyn.sim.catalogue as catalogue
from tendyn.cli import main
from tendyn.errors import flag

TOKENS = ["0", "-1", "1", "2", "3", "0.5", "1e9", "1e400", "nan", "inf", "-inf", "", " ", "abc", "1,2", "1,,2",
          ",", "1.5", "3000", "20000", "1000", "S1", "S3", str(2**64), str(2**64 - 1), "0x10", "1_000", " 5 ",
          "-0.2,0.1,0,0.5", "0,0,0", "0,0,0,0", "1e-9", "true", "[1]"]
DEVICES = ["lexos", "cea_branch", "mcgill_bench"]


def _cases(n, seed=20261201):
    """Mostly experiments the device has and options the experiment uses, so both outcomes are frequent."""
    rng = np.random.default_rng(seed)
    kinds = {"lexos": "serial", "cea_branch": "serial", "mcgill_bench": "tendon_bench_2n"}
    for _ in range(n):
        device = str(rng.choice(DEVICES))
        own = [e for (k, _), e in catalogue.EXPERIMENTS.items() if k == kinds[device]]
        exp = own[rng.integers(len(own))] if rng.random() < 0.9 else None
        name = exp.name if exp else str(rng.choice(catalogue.EXPERIMENT_NAMES))
        pool = list(exp.uses) if exp and rng.random() < 0.9 else list(catalogue.OPTIONS)
        argv = ["simulate", device, name, "--out", "{out}", "--quiet"]
        for opt in rng.choice(pool, size=min(len(pool), rng.integers(1, 4)), replace=False):
            argv += [flag(str(opt)), str(rng.choice(TOKENS))]
        yield argv


class _Accepted(KeyboardInterrupt):
    pass


def test_fuzz_bad_options_never_crash(tmp_path, capsys, monkeypatch):
    """1000 random invocations: exit 2 with one line naming an option or the experiment, or accepted."""
    def accepted(*a, **k):
        raise _Accepted

    monkeypatch.setattr(catalogue, "run", accepted)
    counts = {2: 0, 130: 0}
    for argv in _cases(1000):
        argv = [a.replace("{out}", str(tmp_path / "f.parquet")) for a in argv]
        code = main(argv)
        err = capsys.readouterr().err
        assert code in counts, (argv, err)
        counts[code] += 1
        if code == 2:
            lines = err.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("tendyn: error: "), (argv, err)
    assert counts[2] > 300 and counts[130] > 30, counts   # the pool exercises both sides
    assert list(tmp_path.iterdir()) == []


EDGE = [
    ["lexos", "blocked-link", "--rate", "1000", "--control-rate", "1000", "--log-rate", "1000", "--period", "0.2",
     "--cycles", "1"],
    ["lexos", "blocked-link", "--rate", "20000", "--control-rate", "20000", "--log-rate", "20000", "--period",
     "0.05", "--cycles", "1", "--seed", str(2**64 - 1)],
    ["lexos", "blocked-link", "--q0", "-0.5235987755982988,-0.6981317007977318,0,0", "--period", "0.1",
     "--cycles", "1"],
    ["cea_branch", "blocked-link", "--joint", "3", "--torque", "0.5", "--period", "0.1", "--cycles", "1"],
    ["lexos", "stepped-sine", "--freqs", "2499", "--cycles", "1", "--transmission", "4"],
    ["lexos", "exciting", "--duration", "0.002", "--log-rate", "1000"],
    ["mcgill_bench", "stepped-sine", "--rate", "1000", "--log-rate", "1000", "--freqs", "249", "--cycles", "1"],
    ["mcgill_bench", "swept-sine", "--freqs", "1,2", "--duration", "0.5", "--log-rate", "20000"],
]


@pytest.mark.parametrize("args", EDGE, ids=[" ".join(a[:2]) + f"#{i}" for i, a in enumerate(EDGE)])
def test_accepted_edge_values_run(args, tmp_path, capsys):
    code = main(["simulate", *args, "--out", str(tmp_path / "e.csv"), "--quiet", "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    assert json.loads(cap.out)["logs"]
