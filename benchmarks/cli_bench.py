"""Benchmarks cli_help_latency and identify_tx40_end_to_end (issue 20 item 6, issue 18): wall time of a whole
`tendyn` process, start to exit, median of 7, against the start-up of a bare Python process (`python -c pass`)
measured in the same run. The ratio says how many bare interpreter start-ups a command costs (lower is better,
so it is reported as baseline/tendyn like the other entries: > 1 impossible, closer to 1 is better); the values
are the goals' numbers: ≤ 0.25 s for --help and `routing show lexos`, ≤ 1 s for identify tx40 (process start to
JSON). No peer: a CLI start-up has none to compare with; the baseline is the floor any Python CLI pays."""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "python" / "tendyn" / "data" / "tx40"
TENDYN = Path(sys.executable).with_name("tendyn")


def wall(argv: list[str], repeats: int = 7, cwd=None) -> float:
    """Median wall time [s] of running ``argv`` to completion (stdout/stderr discarded; must exit 0)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=cwd,
                       env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _entry(name: str, value: float, baseline: float) -> dict:
    return {"name": name, "value": value, "unit": "s", "baseline": "python -c pass (process start-up)",
            "baseline_value": baseline, "ratio": baseline / value}


def bench_cli_latency(results: list) -> None:
    base = wall([sys.executable, "-c", "pass"])
    results.append(_entry("cli_help_latency", wall([str(TENDYN), "--help"]), base))
    results.append(_entry("cli_routing_show_latency", wall([str(TENDYN), "routing", "show", "lexos"]), base))


def bench_identify_end_to_end(results: list) -> None:
    """`tendyn identify tx40 tx40.parquet --json`: the shipped 9 s TX40 log (45 000 samples at 5 kHz), imported
    once beforehand with `tendyn log import` (not timed)."""
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "tx40.parquet"
        subprocess.run([str(TENDYN), "log", "import", str(DATA / "pos_read_data.csv"), str(DATA / "curr_data.csv"),
                        "--map", str(DATA / "import.toml"), "--out", str(log)], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        base = wall([sys.executable, "-c", "pass"])
        t = wall([str(TENDYN), "identify", "tx40", str(log), "--json", "--quiet"], cwd=tmp)
        results.append(_entry("identify_tx40_end_to_end", t, base))
