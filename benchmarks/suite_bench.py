"""Benchmark python_suite_wall (issue 39): the wall time of the Python test suite as `make test` runs it (pytest-xdist,
one worker per CPU, modules kept whole) against the same suite one test after another in one process, in the same
run. The ratio is the speed-up of the parallel run; the value is the number to hold under 4 minutes on 2 idle
cores (docs/testing.md). Not a timed test: it only prints. ~15 min on 2 cores (both runs)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _suite_env() -> dict:
    """The environment `make test` gives the suite: the C++ tests' build when one was made (`make test`, `make
    test-cpp`), which the plain-build check installs instead of configuring and compiling one of its own (the C
    ABI at -O3, ~25 s of compiler CPU in each run: without it neither run is the suite `make test` runs)."""
    env = dict(os.environ)
    build = REPO / "build" / "cpp"
    if (build / "CMakeCache.txt").is_file() and (build / "tests" / "cpp" / "test_sim").is_file():
        env.update(TENDYN_CPP_BUILD=str(build), TENDYN_REQUIRE_EXAMPLES="1")
    return env


def _suite(extra: list[str]) -> float:
    """Wall time [s] of ``pytest tests/python -q`` plus ``extra`` (must pass)."""
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "pytest", str(REPO / "tests" / "python"), "-q", "-p", "no:cacheprovider",
                        *extra], cwd=REPO, env=_suite_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True)
    wall = time.perf_counter() - t0
    if r.returncode:
        raise SystemExit(f"python_suite_wall: pytest {' '.join(extra)} failed:\n{r.stdout[-3000:]}")
    return wall


def makefile_xdist(workers: int) -> list[str]:
    """The pytest-xdist options of `make test` (the Makefile's ``XDIST``) for ``workers`` workers."""
    line = re.search(r"^XDIST\s*:=(.*)$", (REPO / "Makefile").read_text("utf-8"), re.M).group(1)
    return line.replace("$(NPROC)", str(workers)).split()


def bench_test_suite(results: list) -> None:
    workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    print(f"[bench] python_suite_wall: the suite on {workers} workers, then serially …", file=sys.stderr)
    parallel = _suite(makefile_xdist(workers))
    serial = _suite(["-p", "no:xdist"])
    results.append(dict(name="python_suite_wall", value=parallel, unit="s",
                        baseline="the same suite serially in one process", baseline_value=serial,
                        ratio=serial / parallel, workers=workers))
