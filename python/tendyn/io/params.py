"""PARAMS.json, the document of ``tendyn identify --out``: the validated reader of its base parameters.

Read by the handle maps (:mod:`tendyn.analysis.operational`) and by the identified model
(:mod:`tendyn.ident.identified`); both import it from here so that one reader checks the file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Mapping

from tendyn.io.files import read_json

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


def read_params(source, device=None, force: bool = False, *, standard_names=None, base_names=None) -> list[dict]:
    """The base parameters of an identification, validated (against ``device`` when given).

    Parameters
    ----------
    source : path, mapping, list or IdentificationResult
        A PARAMS.json file or the document ``tendyn identify --json`` prints (a mapping with ``"params"``), the
        list itself, or an object with ``to_dict()`` giving that document (:class:`tendyn.ident.IdentificationResult`). Each entry needs ``name`` (str), ``value`` (finite) and ``expression`` (str, the
        regrouping, its first term the kept standard column); ``stderr`` (finite ≥ 0, default 0) is used for
        the uncertainty of the maps; ``unit`` and ``rel_stderr_pct`` are informative.

    device : Device, optional
        The device the parameters are used on: a document naming another ``device`` is refused (unless
        ``force``).
    standard_names, base_names : sequence of str, optional
        The device's standard parameters (each expression must start with one) and base parameters (each must be
        given, or named in the document's ``omitted`` list written by ``tendyn identify --essential`` or
        ``--parameters``): a missing parameter is never taken as 0. The caller's model gives them (the
        identification model's for a cable device, :func:`tendyn.device.closed_loop.base_parameters` here).

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
            doc = read_json(source)
        except OSError as exc:
            raise ParamsError(f"cannot read the file: {exc.strerror or exc}", file=file) from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ParamsError(f"not a JSON document: {exc}", file=file) from None
    omitted = None
    if isinstance(doc, Mapping):
        if "params" not in doc:
            raise ParamsError("missing (expected the document of `tendyn identify --json`)", "params", file)
        named = doc.get("device")
        if device is not None and named is not None and not force and not device.is_named(named):
            raise ParamsError(f"the parameters are of {named!r}, not {device.name!r} (--force to use them anyway)",
                              "device", file)
        omitted = doc.get("omitted", [])
        if not isinstance(omitted, list) or not all(isinstance(n, str) for n in omitted):
            raise ParamsError(f"must be a list of parameter names (got {omitted!r})", "omitted", file)
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
    who = device.name if device is not None else "the device"
    if standard_names is not None:                  # a parameter of another device first, then the missing ones
        for i, p in enumerate(out):
            lead = p["expression"].split()[0].lstrip("+")
            if lead not in standard_names:
                raise ParamsError(f"{lead!r} is not a standard parameter of {who} "
                                  f"(known: {', '.join(list(standard_names)[:6])}, …)", f"params[{i}].expression", file)
    if base_names is not None:
        missing = [n for n in base_names if n not in seen and n not in (omitted or ())]
        if missing:
            raise ParamsError(f"missing base parameter(s) {', '.join(missing)} of {who} (never taken as 0; "
                              "an identification that leaves some out lists them in `omitted`)", "params", file)
    return out
