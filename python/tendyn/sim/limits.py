"""The simulators' limits, below every module of :mod:`tendyn.sim`: the integration rates they accept and the
memory guard that refuses a run too large before it starts. The experiments' table
(:mod:`tendyn.sim.catalogue`) and the runners (:mod:`tendyn.sim.model`, :mod:`tendyn.sim.excitation`) read them
from here, so no runner imports the table that calls it."""

from __future__ import annotations

import math
import os

from tendyn.errors import UsageError

__all__ = ["BENCH_RATE_HZ", "CHAIN_RATE_HZ", "MEMORY_SHARE", "memory_available", "require_memory"]

CHAIN_RATE_HZ = (1_000.0, 20_000.0)
"""Integration rates [Hz] the chain simulator accepts (stiff cables, friction impulses)."""
BENCH_RATE_HZ = (1_000.0, 1_000_000.0)
"""Step rates [Hz] of the tendon-bench integrator (it sub-steps internally where needed)."""
MEMORY_SHARE = 0.8
"""A run may use at most this share of the memory available when it starts."""


def memory_available() -> float:
    """Memory [bytes] the system can give now (MemAvailable on Linux, physical memory elsewhere)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def _gb(x: float) -> str:
    return f"{x / 1e9:.0f} GB" if x >= 10e9 else f"{x / 1e9:.1f} GB"


def require_memory(need: float, advice: str, what: str = "this run") -> None:
    """Refuse, before it starts, work whose arrays need ``need`` bytes when that is more than
    :data:`MEMORY_SHARE` of the memory available now (UsageError: exit 2 instead of a MemoryError or the OOM
    killer after minutes). ``advice`` says how to make it smaller. `simulate`, `plan` and `sweep` use it."""
    have = memory_available()
    if need > MEMORY_SHARE * have:
        raise UsageError(f"{what} needs {_gb(need)} of memory and {_gb(have)} are available: {advice}")
