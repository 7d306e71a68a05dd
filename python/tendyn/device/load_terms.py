"""Reading a device file, the ``[[terms]]``: springs, polynomials, tables, offsets and known torques
(:mod:`tendyn.device.terms` evaluates them)."""

from __future__ import annotations

from typing import Any

from .load_fields import _FieldReader
from .schema_fields import TERM_FIELDS
from .schema_parts import Kinematics, Term


class _TermsReader(_FieldReader):
    """The [[terms]] section of a device file."""

    def terms(self, raw: Any, kin: Kinematics) -> tuple[Term, ...]:
        """[[terms]]: torques beyond the rigid bodies (tendyn.device.terms); each kind's fields, joint numbers
        of the tree, expressions that parse, increasing knots, one value per column."""
        import re

        from .terms import check_expression, check_values, joint_range

        out: list[Term] = []
        names: set[str] = set()
        n = kin.n_joints
        tree = [num for num, js in enumerate(kin.joints, start=1) if js.sigma != 2]
        ranges = {num: joint_range(kin.joints[num - 1]) for num in tree}
        for i, item in enumerate(raw or ()):
            path = f"terms[{i + 1}]"
            f = self.table(item, path, TERM_FIELDS)
            name, kind = f["name"], f["kind"]
            if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
                raise self.err(f"{path}.name", f"{name!r}: letters, digits and _ only, starting with a letter")
            if name in names:
                raise self.err(f"{path}.name", f"{name!r} is already the name of another term")
            names.add(name)
            for need in self._TERM_NEEDS[kind]:
                if f[need] in (None, ()):
                    raise self.err(f"{path}.{need}", f"missing required field for kind = {kind!r}")
            if kind == "known" and (f["function"] is None) == (not f["knots"]):
                raise self.err(path, "a known torque is a `function` or a table (`knots`, `torques`), one of them")
            for key in ("joint", "link_a", "link_b"):
                num = f[key]
                if num is None or (num == 0 and key != "joint"):
                    continue
                if num > n:
                    raise self.no_joint(f"{path}.{key}", num, n)
                if num not in tree:
                    raise self.err(f"{path}.{key}", f"joint {num} is a cut joint or fixed frame (sigma = 2)")
            if kind == "spring" and f["link_a"] == f["link_b"]:
                raise self.err(f"{path}.link_b", "a spring between two points of the same link exerts no torque")
            exprs = list(f["functions"]) + ([f["function"]] if kind == "known" and f["function"] else [])
            for k, text in enumerate(exprs):
                try:
                    read = check_expression(text, n)
                    if not read - {0} <= set(tree):
                        raise ValueError(f"reads joint {min(read - {0} - set(tree))}, a cut joint or fixed frame")
                    check_values(text, f["joint"], ranges)
                except ValueError as exc:
                    where = f"{path}.functions[{k + 1}]" if k < len(f["functions"]) else f"{path}.function"
                    shown = repr(text) if len(text) <= 60 else repr(text[:40]) + f"… ({len(text)} characters)"
                    raise self.err(where, f"{shown}: {exc}") from None
            knots = f["knots"]
            if kind in ("table", "known") and knots:
                if len(knots) < 2 or any(b <= a for a, b in zip(knots, knots[1:])):
                    raise self.err(f"{path}.knots", "must be at least 2 strictly increasing positions")
                if kind == "known" and len(f["torques"]) != len(knots):
                    raise self.err(f"{path}.torques", f"{len(f['torques'])} torques for {len(knots)} knots")
            term = Term(name=name, kind=kind, joint=f["joint"], functions=f["functions"], degree=f["degree"],
                        knots=knots, torques=f["torques"], function=f["function"], link_a=f["link_a"],
                        point_a=f["point_a"], link_b=f["link_b"], point_b=f["point_b"],
                        rest_length=f["rest_length"], values=f["values"])
            ncol = len(term.column_names)
            if kind == "known" and f["values"]:
                raise self.err(f"{path}.values", "a known torque has no identifiable column, so no values")
            if f["values"] and len(f["values"]) != ncol:
                raise self.err(f"{path}.values", f"{len(f['values'])} values for {ncol} columns "
                                                 f"({', '.join(term.column_names)})")
            out.append(term)
        return tuple(out)
