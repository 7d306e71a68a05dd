"""Registry, verdicts and the run loop of the claims (no physics here: see s0.py, s1.py, s2.py)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

QUICK_MODES = ("same", "cheaper", "skip")
"""How a check runs under ``--quick``: the same settings, cheaper settings its band allows, or skipped."""


class Verdict:
    """The conditions of one check: each :meth:`that` records a condition and what it says when it fails."""

    def __init__(self):
        self.failed: list[str] = []
        self.numbers: dict[str, object] = {}

    def that(self, condition, what: str) -> bool:
        ok = bool(condition)
        if not ok:
            self.failed.append(what)
        return ok

    def close(self, actual, expected, *, rel: float = 0.0, abs_: float = 0.0, what: str = "") -> bool:
        """|actual − expected| ≤ abs_ + rel·|expected|, element-wise (numbers or arrays)."""
        import numpy as np

        a, e = np.asarray(actual), np.asarray(expected)         # real or complex (frequency responses)
        ok = a.shape == e.shape and bool(np.all(np.abs(a - e) <= abs_ + rel * np.abs(e)))
        return self.that(ok, f"{what}: {np.array2string(a, precision=6)} vs {np.array2string(e, precision=6)}")


@dataclass(frozen=True)
class Claim:
    """One check of a claim. ``key`` is the claim id (``C22``) or, when a claim has several checks, the id and a
    part (``C42:natural``); ``measure(ctx, verdict)`` returns tendyn's value as text and records its conditions."""

    key: str
    paper: str                      # S0, S1 or S2
    statement: str                  # what the paper claims (CLAIMS.md, shortened)
    paper_value: str
    band: str
    measure: Callable
    quick: str = "same"
    xfail: str | None = None        # reason, when the check is a strict expected failure today
    tests: tuple[str, ...] = ()     # the tests that call it (file::name)

    @property
    def id(self) -> str:
        return self.key.split(":")[0]


REGISTRY: dict[str, Claim] = {}


def claim(key: str, paper: str, statement: str, paper_value: str, band: str, *, quick: str = "same",
          xfail: str | None = None, tests: tuple[str, ...] = ()):
    """Decorator registering ``measure(ctx, v) -> str`` as the check ``key``."""
    if quick not in QUICK_MODES:
        raise ValueError(f"quick must be one of {QUICK_MODES}")

    def register(fn):
        if key in REGISTRY:
            raise ValueError(f"claim {key} registered twice")
        REGISTRY[key] = Claim(key, paper, statement, paper_value, band, fn, quick, xfail, tests)
        return fn

    return register


@dataclass
class Outcome:
    """The result of one check. ``status``: holds, FAILS (a claim that held fails: exit 1), xfail (the expected
    failure, reason in ``reason``), XPASS (an expected failure now holds: promote it), skipped (``--quick``),
    ERROR (the check raised: counted as a failure)."""

    key: str
    status: str
    value: str = ""
    failed: list[str] = field(default_factory=list)
    reason: str = ""
    seconds: float = 0.0

    @property
    def holds(self) -> bool:
        return self.status in ("holds", "XPASS")

    @property
    def bad(self) -> bool:
        return self.status in ("FAILS", "ERROR")

    def to_dict(self) -> dict:
        c = REGISTRY[self.key]
        return {"claim": self.key, "paper": c.paper, "statement": c.statement, "paper_value": c.paper_value,
                "band": c.band, "tendyn_value": self.value, "status": self.status, "failed_conditions": self.failed,
                "reason": self.reason, "seconds": round(self.seconds, 3)}


class Context:
    """The twins and the expensive runs the checks share, computed on first use. ``quick=True`` selects the cheaper
    settings of the checks whose band allows them (see each claim's ``quick``)."""

    def __init__(self, quick: bool = False, seed: int = 20261122, count: int | None = None):
        self.quick = quick
        self.seed = seed                                        # of the randomised checks (C1, C3)
        self.count = count if count is not None else (200 if quick else 1000)   # random cases per such check
        self._cache: dict[str, object] = {}

    def rng(self):
        import numpy as np

        return np.random.default_rng(self.seed)

    def get(self, name: str, make: Callable[[], object]):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]


def _registry() -> dict[str, Claim]:
    """REGISTRY with every paper's checks registered. The checks register themselves (``@claim``) when their
    modules are imported, which the package face :mod:`tendyn.claims` does before any of its modules runs (Python
    imports a package's face first), so the core imports none of its children: no circle."""
    return REGISTRY


def claim_ids() -> list[str]:
    """Every check key, in the papers' order (C1 … C46, parts after their claim)."""
    def order(k):
        head, _, part = k.partition(":")
        return int(head[1:]), part

    return sorted(_registry(), key=order)


def xfail_reason(key: str) -> str:
    """The reason of a strict expected failure (for ``pytest.mark.xfail(strict=True, reason=…)``)."""
    reason = _registry()[key].xfail
    if not reason:
        raise KeyError(f"{key} is not an expected failure")
    return reason


def check(key: str, ctx: Context | None = None) -> Outcome:
    """Run one check. Exceptions become ``ERROR`` (the command never shows a traceback)."""
    c = _registry()[key]
    ctx = ctx or Context()
    if ctx.quick and c.quick == "skip":
        return Outcome(key, "skipped", reason="skipped with --quick (too long for its band)")
    v = Verdict()
    t0 = time.perf_counter()
    try:
        value = c.measure(ctx, v)
    except Exception as exc:  # noqa: BLE001 — reported as the check's outcome
        return Outcome(key, "ERROR", failed=[f"{type(exc).__name__}: {exc}"], seconds=time.perf_counter() - t0,
                       reason=c.xfail or "")
    dt = time.perf_counter() - t0
    if c.xfail:
        return Outcome(key, "xfail" if v.failed else "XPASS", str(value), v.failed, c.xfail, dt)
    return Outcome(key, "FAILS" if v.failed else "holds", str(value), v.failed, "", dt)


def assert_claim(key: str, ctx: Context | None = None) -> Outcome:
    """Run a check inside a test: AssertionError naming the failed conditions unless the claim holds (strict
    expected failures are marked ``xfail(strict=True, reason=xfail_reason(key))`` in their test)."""
    c = _registry()[key]
    v = Verdict()
    value = c.measure(ctx or Context(), v)
    if v.failed:
        raise AssertionError(f"{key} ({c.band}): tendyn {value}; failed: " + "; ".join(v.failed))
    return Outcome(key, "holds", str(value))


def run(keys=None, ctx: Context | None = None, progress: Callable[[str, int, int], None] | None = None) -> list[Outcome]:
    """Run the checks ``keys`` (default: all) in order; ``progress(key, done, total)`` before each."""
    keys = claim_ids() if keys is None else list(keys)
    ctx = ctx or Context()
    out = []
    for i, k in enumerate(keys):
        if progress:
            progress(k, i, len(keys))
        out.append(check(k, ctx))
    if progress:
        progress("", len(keys), len(keys))
    return out
