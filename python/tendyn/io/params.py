"""PARAMS.json, the document of ``tendyn identify --out``: the validated reader of its base parameters.

Read by the handle maps (:mod:`tendyn.analysis.operational`) and by the identified model
(:mod:`tendyn.ident.identified`); both import it from here so that one reader checks the file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Mapping

__all__ = ["ParamsError", "read_params"]


class ParamsError(ValueError):
    """A parameters document that does not follow the identification contract; the message names the field
    (``params[3].value: must be a finite number (got 'abc')``) and, when known, the file."""

    def __init__(self, problem: str, field: str | None = None, file: str | None = None):
        self.problem, self.field, self.file = problem, field, file
        where = ": ".join(p for p in (file, field) if p)
        super().__init__(f"{where}: {problem}" if where else problem)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def read_params(source) -> list[dict]:
    """The base parameters of an identification, validated.

    Parameters
    ----------
    source : path, mapping, list or IdentificationResult
        A PARAMS.json file or the document ``tendyn identify --json`` prints (a mapping with ``"params"``), the
        list itself, or an object with ``to_dict()`` giving that document (:class:`tendyn.ident.IdentificationResult`). Each entry needs ``name`` (str), ``value`` (finite) and ``expression`` (str, the
        regrouping, its first term the kept standard column); ``stderr`` (finite ≥ 0, default 0) is used for
        the uncertainty of the maps; ``unit`` and ``rel_stderr_pct`` are informative.

    Raises
    ------
    ParamsError
        Naming the file and the field (``params[2].expression``).
    """
    file = None
    doc = source.to_dict() if hasattr(source, "to_dict") and not isinstance(source, Mapping) else source
    if isinstance(source, (str, Path)):
        file = str(source)
        try:
            doc = json.loads(Path(source).read_text(encoding="utf-8"))
        except OSError as exc:
            raise ParamsError(f"cannot read the file: {exc.strerror or exc}", file=file) from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ParamsError(f"not a JSON document: {exc}", file=file) from None
    if isinstance(doc, Mapping):
        if "params" not in doc:
            raise ParamsError("missing (expected the document of `tendyn identify --json`)", "params", file)
        doc = doc["params"]
    if not isinstance(doc, list) or not doc:
        raise ParamsError("must be a non-empty list of parameters", "params", file)
    out, seen = [], set()
    for i, p in enumerate(doc):
        where = f"params[{i}]"
        if not isinstance(p, Mapping):
            raise ParamsError("must be an object {name, value, stderr, expression, …}", where, file)
        name = p.get("name")
        if not isinstance(name, str) or not name:
            raise ParamsError(f"must be a non-empty string (got {name!r})", f"{where}.name", file)
        if name in seen:
            raise ParamsError(f"duplicate parameter {name!r}", f"{where}.name", file)
        seen.add(name)
        if not _finite(p.get("value")):
            raise ParamsError(f"must be a finite number (got {p.get('value')!r})", f"{where}.value", file)
        se = p.get("stderr", 0.0)
        se = 0.0 if se is None else se
        if not _finite(se) or se < 0:
            raise ParamsError(f"must be a finite number >= 0 (got {se!r})", f"{where}.stderr", file)
        expr = p.get("expression")
        if not isinstance(expr, str) or not expr.strip():
            raise ParamsError(f"must be the regrouping as text, e.g. 'ZZ1 + 1.0*IA1' (got {expr!r})",
                              f"{where}.expression", file)
        out.append({"name": name, "value": float(p["value"]), "stderr": float(se), "unit": p.get("unit", ""),
                    "expression": expr.strip()})
    return out
