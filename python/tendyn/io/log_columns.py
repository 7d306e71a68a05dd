"""The column registry of experiment logs (schema version 1): every column name matches one entry of
:data:`COLUMNS` (name pattern, unit, meaning), indices 1-based; the unit of a column in a given log."""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

@dataclass(frozen=True)
class ColumnSpec:
    """One entry of the column registry.

    Parameters
    ----------
    name : str
        Name template as documented, ``<i>`` for a 1-based transmission/motor index, ``<j>`` for a joint.
    unit : str
        SI unit of the values.
    description : str
        One-line meaning (also used in ``docs/logs.md``).
    """

    name: str
    unit: str
    description: str

    @property
    def indexed(self) -> bool:
        """Whether the name ends with a 1-based index (``q_motor_<i>``)."""
        return self.name.endswith(">")

    @property
    def base(self) -> str:
        """The name without the index placeholder (``q_motor_``), or the full name if not indexed."""
        return self.name[: self.name.rindex("<")] if self.indexed else self.name

    @property
    def pattern(self) -> re.Pattern:
        """Regular expression a column name must fully match (indices: 1, 2, …, no leading zero)."""
        return re.compile(re.escape(self.base) + r"([1-9][0-9]*)" if self.indexed else re.escape(self.name))


COLUMNS: tuple[ColumnSpec, ...] = (
    ColumnSpec("time", "s", "sample time (required, the first column, strictly increasing)"),
    ColumnSpec("q_motor_<i>", "rad", "measured motor position (quantised encoder)"),
    ColumnSpec("qd_motor_<i>", "rad/s", "motor velocity (estimate)"),
    ColumnSpec("q_joint_<j>", "rad", "joint position (when sensed, or the simulator's truth in a truth-only log)"),
    ColumnSpec("qd_joint_<j>", "rad/s", "joint velocity"),
    ColumnSpec("torque_motor_<i>", "N·m", "measured motor torque (k_t × measured current)"),
    ColumnSpec("torque_motor_cmd_<i>", "N·m", "commanded motor torque"),
    ColumnSpec("current_<i>", "A", "measured motor current"),
    ColumnSpec("q_ref_<j>", "rad", "joint position reference of the controller"),
    ColumnSpec("qd_ref_<j>", "rad/s", "joint velocity reference of the controller"),
    ColumnSpec("q_motor_ref_<i>", "rad", "motor position reference (motor space)"),
    ColumnSpec("qd_motor_ref_<i>", "rad/s", "motor velocity reference (motor space)"),
    ColumnSpec("torque_joint_ext_<j>", "N·m", "external torque applied on joint j (blocked-link tests, user)"),
    ColumnSpec("force_cmd", "N", "commanded tendon force (McGill tendon bench)"),
    ColumnSpec("force_tendon", "N", "sensed differential tendon force (McGill tendon bench)"),
    ColumnSpec("force_ref", "N", "tendon force reference of a closed loop (McGill tendon bench; controller in meta.options)"),
    ColumnSpec("x_tendon", "m", "sensed tendon displacement (McGill tendon bench)"),
    ColumnSpec("current_cmd", "A", "commanded motor current (McGill tendon bench)"),
    ColumnSpec("input_<k>", "*", "generic input signal k of a bench (any unit: its name and unit in meta.signals)"),
    ColumnSpec("output_<k>", "*", "generic output signal k of a bench (any unit: its name and unit in meta.signals)"),
)
"""The column registry of schema version 1: every column of a log matches exactly one entry."""

_PATTERNS = tuple((spec, spec.pattern) for spec in COLUMNS)

GENERIC_UNIT = "*"
"""Registry unit of the generic columns ``input_<k>`` / ``output_<k>``: the unit is the log's own,
declared with the signal's name in ``meta.signals`` (``{"input_1": {"name": "voltage", "unit": "V"}}``)."""

UNIT_ALIASES: dict[str, tuple[str, ...]] = {"N·m": ("N.m", "N*m", "Nm", "N m", "N⋅m")}
"""ASCII spellings accepted in a CSV header for a registry unit (the files we write use the registry unit)."""


LINEAR_UNITS: dict[str, str] = {"rad": "m", "rad/s": "m/s", "N·m": "N"}
"""The unit a position, velocity or torque column holds instead of the registry's when it belongs to a
prismatic joint or a linear motor (metres, m/s, newtons); a log declares such columns in ``meta.units``
(``{"q_motor_1": "m", "torque_motor_1": "N"}``)."""


def column_spec(name: str) -> ColumnSpec | None:
    """The registry entry a column name matches, or None."""
    if not isinstance(name, str):
        return None
    for spec, pat in _PATTERNS:
        if pat.fullmatch(name):
            return spec
    return None


def _column_index(name: str, prefix: str) -> int | None:
    """The 1-based index of ``name`` if it is ``prefix`` followed by an index, else None."""
    if name.startswith(prefix):
        rest = name[len(prefix):]
        if rest.isascii() and rest.isdigit() and not rest.startswith("0"):
            return int(rest)
    return None


def _suggest(name: str) -> str:
    """A hint for an unknown column name: the closest registry entry."""
    m = re.fullmatch(r"(.*?)_?([0-9]+)", name) if isinstance(name, str) else None
    idx = int(m.group(2)) if m else None
    if m and idx == 0 and column_spec(m.group(1) + "_1") is not None:
        return f"; indices are 1-based (did you mean {m.group(1)}_1?)"
    candidates = {}
    for spec in COLUMNS:
        example = spec.base + str(idx if idx else 1) if spec.indexed else spec.name
        candidates[example] = spec
    close = difflib.get_close_matches(str(name), list(candidates), n=1, cutoff=0.6)
    if close:
        spec = candidates[close[0]]
        return f"; did you mean {close[0]} ({spec.name} [{spec.unit}], {spec.description})?"
    return "; known columns: " + ", ".join(s.name for s in COLUMNS)


def is_generic(name: str) -> bool:
    """Whether a column is a generic ``input_<k>`` / ``output_<k>`` (unit and name in ``meta.signals``)."""
    spec = column_spec(name)
    return spec is not None and spec.unit == GENERIC_UNIT


def column_unit(name: str, meta: dict) -> str:
    """The unit of column ``name`` in a log with ``meta``: the registry's, for a generic column the one
    declared in ``meta["signals"]``, for a linear column (prismatic joint, linear motor) ``meta["units"]``'s."""
    if is_generic(name):
        return meta["signals"][name]["unit"]
    return meta.get("units", {}).get(name) or column_spec(name).unit


def _unit_matches(found: str, expected: str) -> bool:
    return found == expected or found in UNIT_ALIASES.get(expected, ())
