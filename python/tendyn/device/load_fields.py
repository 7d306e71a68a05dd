"""Reading a device file, the generic part: one value against its :class:`~tendyn.device.schema_fields.FieldSpec`
(type, range, finiteness, list length), a table with only known keys, a physical inertia, and the
:class:`~tendyn.device.base.DeviceError` that names the file and the field."""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any

import numpy as np

from tendyn.text import name_problem, text_problem

from ._toml import typename as _typename
from .base import DeviceError
from .schema_fields import INERTIA_TOL, FieldSpec, _num
from .schema_parts import inertia_matrix


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return repr(x)
    return str(x)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


class _FieldReader:
    """Walks the parsed TOML dict; knows the file for the messages."""

    def __init__(self, path: Path):
        self.path = path
        self.fname = path.name

    # -- errors ----------------------------------------------------------------------------------------
    def no_joint(self, field: str, number: int, n: int) -> DeviceError:
        """The error for a joint number the device does not have."""
        return self.err(field, f"no joint {number}: the device has {n} joint{'s' if n != 1 else ''}")

    def err(self, field: str | None, problem: str) -> DeviceError:
        return DeviceError(problem, file=self.fname, field=field or None)

    # -- generic values --------------------------------------------------------------------------------
    def table(self, raw: Any, path: str, specs: tuple[FieldSpec, ...], what: str = "a table") -> dict:
        """Check that raw is a table with only known keys, and read every spec'd field."""
        if not isinstance(raw, dict):
            raise self.err(path, f"must be {what} (got {_typename(raw)})")
        known = [s.name for s in specs]
        for key in raw:
            if key not in known:
                close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
                hint = f" (did you mean {close[0]!r}?)" if close else f" (known fields: {', '.join(known)})"
                raise self.err(_join(path, key), f"unknown field{hint}")
        out = {}
        for spec in specs:
            fpath = _join(path, spec.name)
            if spec.name not in raw:
                if spec.required:
                    raise self.err(fpath, f"missing required field: {spec.doc}")
                out[spec.name] = spec.default
            else:
                out[spec.name] = self.value(raw[spec.name], fpath, spec)
        return out

    def value(self, v: Any, path: str, spec: FieldSpec) -> Any:
        kind = spec.kind
        if spec.max_items is not None and isinstance(v, list) and len(v) > spec.max_items:
            raise self.err(path, f"{len(v)} entries, more than the {spec.max_items} allowed")
        if kind in ("name", "text"):        # text from a file: a declared domain (tendyn.text, issue 36)
            if not isinstance(v, str):
                raise self.err(path, f"must be a string (got {_typename(v)})")
            problem = name_problem(v) if kind == "name" else text_problem(v)
            if problem:
                raise self.err(path, problem)
            return v
        if kind == "str":
            if not isinstance(v, str):
                raise self.err(path, f"must be a string (got {_typename(v)})")
            if spec.choices and v not in spec.choices:
                raise self.err(path, f"must be one of {', '.join(repr(c) for c in spec.choices)} (got {v!r})")
            if spec.name == "name" and not v.strip():
                raise self.err(path, "must not be empty")
            return v
        if kind == "float":
            return self.number(v, path, spec)
        if kind == "bool":
            if not isinstance(v, bool):
                raise self.err(path, f"must be true or false (got {_typename(v)})")
            return v
        if kind == "int":
            return self.integer(v, path, spec)
        if kind in ("vec3", "inertia"):
            n = 3 if kind == "vec3" else 6
            what = "3 numbers [x, y, z]" if n == 3 else "6 numbers [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]"
            if not isinstance(v, list) or len(v) != n:
                got = f"{len(v)} elements" if isinstance(v, list) else _typename(v)
                raise self.err(path, f"must be an array of {what} (got {got})")
            return tuple(self.number(x, f"{path}[{k + 1}]", spec) for k, x in enumerate(v))
        if kind == "int_list":
            if not isinstance(v, list):
                raise self.err(path, f"must be an array of integers (got {_typename(v)})")
            return tuple(self.integer(x, f"{path}[{k + 1}]", spec) for k, x in enumerate(v))
        if kind == "str_list":
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise self.err(path, f"must be an array of strings (got {_typename(v)})")
            return tuple(v)
        if kind == "float_list":
            if not isinstance(v, list):
                raise self.err(path, f"must be an array of numbers (got {_typename(v)})")
            return tuple(self.number(x, f"{path}[{k + 1}]", spec) for k, x in enumerate(v))
        if kind == "table":
            if not isinstance(v, dict):
                raise self.err(path, f"must be a table (got {_typename(v)})")
            return v
        if kind == "table_list":
            if not isinstance(v, list):
                raise self.err(path, f"must be an array of tables, e.g. [[{path}]] or [{{...}}, ...] "
                                     f"(got {_typename(v)})")
            for k, item in enumerate(v):
                if not isinstance(item, dict):
                    raise self.err(f"{path}[{k + 1}]", f"must be a table (got {_typename(item)})")
            return v
        raise AssertionError(f"unknown field kind {kind!r}")  # pragma: no cover - programming error

    def number(self, v: Any, path: str, spec: FieldSpec) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            extra = ": booleans are not numbers" if isinstance(v, bool) else ""
            raise self.err(path, f"must be a number (got {_typename(v)}){extra}")
        x = float(v)
        if not math.isfinite(x):
            raise self.err(path, f"must be finite (got {_fmt(x)})")
        self.check_range(x, path, spec)
        return x

    def integer(self, v: Any, path: str, spec: FieldSpec) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            extra = ": booleans are not numbers" if isinstance(v, bool) else ""
            raise self.err(path, f"must be an integer (got {_typename(v)}){extra}")
        if spec.choices and v not in spec.choices:
            raise self.err(path, f"must be one of {', '.join(str(c) for c in spec.choices)} (got {v})")
        self.check_range(v, path, spec)
        return int(v)

    def check_range(self, x: float, path: str, spec: FieldSpec) -> None:
        problem = None
        if spec.lo is not None and (x <= spec.lo if spec.lo_open else x < spec.lo):
            problem = f"must be {'>' if spec.lo_open else '>='} {_num(spec.lo)}"
        elif spec.hi is not None and (x >= spec.hi if spec.hi_open else x > spec.hi):
            problem = f"must be {'<' if spec.hi_open else '<='} {_num(spec.hi)}"
        elif spec.abs_max is not None and abs(x) > spec.abs_max:
            problem = f"must satisfy |value| <= {_num(spec.abs_max)}"
        elif spec.nonzero and x == 0:
            problem = "must be nonzero"
        if problem is None:
            return
        if spec.range_msg and not (spec.nonzero and x == 0):
            problem = spec.range_msg
        msg = f"{problem} (got {_fmt(x)})"
        if spec.zero_hint and x == 0:
            msg += f": {spec.zero_hint}"
        raise self.err(path, msg)

    def inertia(self, v: tuple, path: str) -> None:
        """Raise unless v = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] is a physical inertia about the COM."""
        tol = INERTIA_TOL
        ixx, iyy, izz = v[:3]
        ev = np.linalg.eigvalsh(inertia_matrix(v))
        if ev[0] < -tol:
            raise self.err(path, f"not a physical inertia: not positive semidefinite (smallest principal "
                                 f"moment {ev[0]:.6g} kg m^2)")
        for (a, an), (b, bn), (c, cn) in (((ixx, "Ixx"), (iyy, "Iyy"), (izz, "Izz")),
                                           ((ixx, "Ixx"), (izz, "Izz"), (iyy, "Iyy")),
                                           ((iyy, "Iyy"), (izz, "Izz"), (ixx, "Ixx"))):
            if a + b < c - tol:
                raise self.err(path, f"not a physical inertia: violates the triangle inequality "
                                     f"{an} + {bn} >= {cn} ({_fmt(a)} + {_fmt(b)} < {_fmt(c)})")
        if ev[0] + ev[1] < ev[2] - tol:
            raise self.err(path, f"not a physical inertia: principal moments {ev[0]:.6g}, {ev[1]:.6g}, "
                                 f"{ev[2]:.6g} violate the triangle inequality")
