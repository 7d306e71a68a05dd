"""Benchmark closed_loop_identify: ``tendyn identify --method iv`` and ``--method didim`` end to end (process start,
log read, LS start, closed-loop simulations, PARAMS document) on a twin log of the TX40 log's size (a
generated 6-joint cable device, 9 s, joint-space PID written in the log's meta, logged at 1 kHz), against ``--method ols`` on the same log in
the same run (ratio = LS time / method time: < 1, the price of removing the closed-loop bias)."""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _twin_log(folder: Path) -> tuple[Path, Path]:
    """A generated 6-joint spatial cable device (the bundled TX40 has no twin: no drives) and its 9 s exciting
    run logged at 1 kHz: the TX40 log's joints and duration."""
    from tendyn.device import load_device
    from tendyn.devices.generate import write_cable_device
    from tendyn.io import write_log
    from tendyn.sim.experiments import exciting_trajectory

    dev = write_cable_device(folder, 6, planar=False, seed=6)
    run = exciting_trajectory(load_device(dev), duration=9.0, seed=0, log_rate_hz=1000.0)
    path = folder / "gen6_twin.parquet"
    write_log(run.log, path)
    return dev, path


def _time(args, repeats: int = 2) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "tendyn.cli", *args], check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t0)
    return best


def bench_closed_loop_identify(results: list) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        dev, log = _twin_log(Path(tmp))
        base = ["identify", str(dev), str(log), "--quiet", "--json"]
        ls = _time(base + ["--method", "ols"])
        for m in ("iv", "didim"):
            t = _time(base + ["--method", m], repeats=1)
            results.append(dict(name=f"identify_{m}_gen6_twin_end_to_end", value=t, unit="s",
                                baseline="tendyn identify --method ols, same log, same run", baseline_value=ls,
                                ratio=ls / t))


if __name__ == "__main__":
    out: list = []
    bench_closed_loop_identify(out)
    for r in out:
        print(r)
