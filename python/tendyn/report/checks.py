"""Warnings for implausible values in a command's JSON document, for the report's warning box and stderr.

Reads only the document (computes nothing new): a negative friction coefficient or inertia, a relative
standard deviation %σ above 100 %, an efficiency outside [0, 1], and the warnings the results carry themselves
(``warnings`` lists at any depth, e.g. :func:`tendyn.ident.estimate.implausible`, a sweep's peaks at the edge of
its frequency grid). Which keys count is written in the tables below, in one place.
"""

from __future__ import annotations

import math
import re

__all__ = ["scan", "MUST_BE_NONNEGATIVE", "MAX_REL_STDERR_PCT"]

MUST_BE_NONNEGATIVE = re.compile(r"(^|_)(coulomb|viscous|friction|inertia|mass|stiffness)(_|$)", re.I)
"""JSON keys whose numbers cannot be negative on a real device (friction coefficients, inertias, masses,
stiffnesses [their SI units])."""

EFFICIENCY = re.compile(r"(^|_)(efficiency|eta)(_|$)", re.I)
"""JSON keys of efficiencies [-], physically within [0, 1]."""

MAX_REL_STDERR_PCT = 100.0
"""%σ above this [%]: the parameter is not determined by the data (its σ is larger than its value)."""

_SKIP = re.compile(r"(^|_)(signed|offset|residual|error|delta|shift|change|diff|direction|dir|axis|vector|sign|"
                   r"position|ratio_re|ratio_im|phase)(_|$)", re.I)
"""Keys that are differences, directions or signed by construction, never checked for sign."""


def _numbers(v):
    if isinstance(v, bool):
        return []
    if isinstance(v, (int, float)):
        return [float(v)]
    if isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        return [float(x) for x in v]
    return []


def scan(doc, where: str = "") -> list[str]:
    """Warnings (sentences) for the implausible values of a JSON-able document, each naming its path."""
    out: list[str] = []
    if isinstance(doc, dict):
        name = doc.get("name")
        p = doc.get("rel_stderr_pct")
        if isinstance(p, (int, float)) and not isinstance(p, bool) and math.isfinite(p) and p > MAX_REL_STDERR_PCT:
            label = name if isinstance(name, str) else where or "a parameter"
            out.append(f"{label}: relative standard deviation {p:.3g} % > {MAX_REL_STDERR_PCT:g} % — the data do "
                       "not determine it (its σ exceeds its value)")
        for key, value in doc.items():
            path = f"{where}.{key}" if where else str(key)
            if key == "warnings" and isinstance(value, list):
                out += [str(w) for w in value if isinstance(w, str)]
                continue
            nums = _numbers(value)
            if nums and MUST_BE_NONNEGATIVE.search(key) and not _SKIP.search(key):
                bad = [x for x in nums if x < 0]
                if bad:
                    out.append(f"{path} = {min(bad):.4g} is negative: a friction coefficient, inertia, mass or "
                               "stiffness cannot be")
            if nums and EFFICIENCY.search(key):
                bad = [x for x in nums if not 0.0 <= x <= 1.0]
                if bad:
                    out.append(f"{path} = {bad[0]:.4g} is outside [0, 1]: an efficiency cannot be")
            if isinstance(value, (dict, list)) and not nums:
                out += scan(value, path)
    elif isinstance(doc, list):
        for k, v in enumerate(doc):
            out += scan(v, f"{where}[{k}]")
    seen: set = set()
    return [w for w in out if not (w in seen or seen.add(w))]
