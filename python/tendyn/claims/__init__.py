"""The papers' claims C1–C46 (``../shared/CLAIMS.md``) as checks: one definition for the test suite and for
``tendyn claims``.

Each check is a :class:`Claim` in :data:`REGISTRY`: the claim's id, the paper's value, the band tendyn must land
in, a function that computes tendyn's value on the twins, and whether it holds today or is a strict expected
failure (with the reason). The tests (``tests/python/test_*.py``, a test per claim named ``test_Cn_…``) call
:func:`assert_claim`; the command calls :func:`run`. Expensive artefacts (the S1/S2 pipelines, the Fig. 7 hand
runs, …) are computed once per :class:`Context` and shared by the checks that read them.

Examples
--------
>>> from tendyn.claims import REGISTRY, Context, check
>>> REGISTRY["C6"].paper_value
'η_d = 0.9 → η_i = 0.8889; η_d ≤ 0.5 self-locking'
>>> check("C6", Context(quick=True)).status
'holds'
"""

from __future__ import annotations

from tendyn.claims.core import (QUICK_MODES, REGISTRY, Claim, Context, Outcome, Verdict, assert_claim, check,
                                claim_ids, run, xfail_reason)
from tendyn.claims import s0, s1, s2  # noqa: E402,F401 — the checks register themselves in REGISTRY

__all__ = ["QUICK_MODES", "REGISTRY", "Claim", "Context", "Outcome", "Verdict", "assert_claim", "check", "claim_ids",
           "run", "xfail_reason"]
