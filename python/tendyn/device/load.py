"""Read and validate a device file (TOML, schema version 1).

:func:`load_device` is the only entry point. Every problem a user can cause raises one
:class:`~tendyn.device.schema.DeviceError` whose message names the file, the field path (array entries
counted from 1, as joints and transmissions are numbered in the file) and what is wrong; the first problem
found is reported.
"""

from __future__ import annotations

import difflib
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from . import routing_checks
from .base import DeviceError
from .schema_fields import (ACTUATOR_FIELDS, BEARING_FIELDS, CONSTRAINT_FIELDS, DEVICE_FIELDS, DH_JOINT_FIELDS,
                            DRIVE_FIELDS, FRICTION_FIELDS, GRAVITY_MAX_NORM, INERTIA_TOL, KINEMATICS_FIELDS,
                            MDH_JOINT_FIELDS, MOTOR_FIELDS, SCHEMA_VERSION, SENSOR_FIELDS, TERM_FIELDS, TOP_FIELDS,
                            TRANSMISSION_FIELDS, FieldSpec, _num)
from .schema_parts import (Actuator, Bearing, BranchFriction, Constraint, Drive, JointSpec, Kinematics, Motor,
                           Sensors, Term, TransmissionSpec, _frozen_array, inertia_matrix)
from .serial_device import SerialDevice
from tendyn.text import name_problem, text_problem

from ._toml import read_toml, typename as _typename
from .base import Device
from .tendon_bench import KIND as TENDON_BENCH_KIND
from .tendon_bench import load_tendon_bench

__all__ = ["load_device"]


def load_device(path: str | os.PathLike) -> Device:
    """Load and validate a device file.

    Parameters
    ----------
    path : str or os.PathLike
        The TOML device file (schema version 1, see ``docs/device-file.md``).

    Returns
    -------
    Device
        The validated, immutable description: a :class:`~tendyn.device.schema.SerialDevice`
        (transmissions or drives sorted by driven joint), or for a file with
        ``[device] kind = "tendon_bench_2n"`` the :class:`~tendyn.device.tendon_bench.TendonBench` of
        ``tendyn.device.tendon_bench.load_tendon_bench``. Every kind shares the base
        :class:`~tendyn.device.base.Device` (``kind``, ``name``, ``path``, ``experiments``).

    Raises
    ------
    DeviceError
        For any problem with the file (missing, TOML syntax, unknown or missing field, wrong type, value
        out of range, inconsistent routing, ...). The message names the file, the field and the problem.
    """
    p = Path(path)
    raw = read_toml(p)
    dev_table = raw.get("device")
    if isinstance(dev_table, dict) and dev_table.get("kind") == TENDON_BENCH_KIND:
        return load_tendon_bench(p, raw)
    return _Parser(p).device(raw)


# ----------------------------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------------------------

def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return repr(x)
    return str(x)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


class _Parser:
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

    # -- sections ----------------------------------------------------------------------------------------
    def device(self, raw: dict) -> SerialDevice:
        # The version decides what the rest means: check it before anything else.
        if "schema" not in raw:
            raise self.err("schema", f"missing required field: write `schema = {SCHEMA_VERSION}` at the top")
        schema = raw["schema"]
        if isinstance(schema, bool) or not isinstance(schema, int):
            raise self.err("schema", f"must be an integer (got {_typename(schema)})")
        if schema != SCHEMA_VERSION:
            raise self.err("schema", f"unsupported schema version {schema}: this version of tendyn reads "
                                     f"schema = {SCHEMA_VERSION}")
        top = self.table(raw, "", TOP_FIELDS)
        dev = self.table(top["device"], "device", DEVICE_FIELDS)
        if dev["kind"] != "serial":
            raise self.err("device.kind", f"kind {dev['kind']!r} is read by its own loader: use "
                                          "tendyn.device.load_device on the file")
        kin = self.kinematics(top["kinematics"])
        trans: tuple = ()
        drives: tuple = ()
        if top["transmissions"] is not None and top["drives"] is not None:
            raise self.err("drives", "not allowed together with [[transmissions]]: a device has cable "
                                     "transmissions or elastic capstan drives, not both")
        actuators: tuple = ()
        if dev["routing"] != "one_per_joint" and top["transmissions"] is None:
            raise self.err("device.routing", f"routing {dev['routing']!r} needs [[transmissions]] (tendons with "
                                             "radii): [[drives]] and [[actuators]] have one motor per joint")
        if top["actuators"] is not None:
            other = "transmissions" if top["transmissions"] is not None else "drives" if top["drives"] is not None else None
            if other:
                raise self.err("actuators", f"not allowed together with [[{other}]]: a device has one kind of "
                                            "actuation ([[transmissions]], [[drives]] or [[actuators]])")
            actuators = self.actuators(top["actuators"], kin)
        elif top["drives"] is not None:
            drives = self.drives(top["drives"], kin)
        elif top["transmissions"] is not None:
            passive = [f"{num} ({js.name})" for num, js in enumerate(kin.joints, start=1)
                       if getattr(js, "mu", 1) == 0 and getattr(js, "sigma", 0) != 2]
            if passive:   # the cable statics (S0 eqs. 1-5) route over every joint of a serial chain
                raise self.err("transmissions", f"cable [[transmissions]] route over the joints of a serial chain; "
                                                f"this tree has passive joints {', '.join(passive)} (closed loops): "
                                                "write its capstans as [[drives]] (docs/device-file.md, 'A desktop "
                                                "haptic arm')")
            trans = self.transmissions(top["transmissions"], kin, dev["routing"])
        else:
            raise self.err("transmissions", "missing required field: one [[transmissions]] entry per actuated "
                                            "joint (or [[drives]] for elastic capstan drives)")
        home = dev["home_pose"]
        if home is not None:
            joints = kin.joints
            if len(home) != len(joints):
                raise self.err("device.home_pose", f"{len(home)} values, the device has {len(joints)} joints")
            for k, (q, j) in enumerate(zip(home, joints)):
                if j.lower is not None and j.upper is not None and not j.lower <= q <= j.upper:
                    raise self.err(f"device.home_pose[{k + 1}]", f"{q:g} rad is outside joint {k + 1}'s limits "
                                                                 f"[{j.lower:g}, {j.upper:g}]")
            home = tuple(float(q) for q in home)
        terms = self.terms(top["terms"], kin)
        self.plausible(kin, trans, drives)
        device = SerialDevice(name=dev["name"], description=dev["description"], path=self.path.resolve(),
                            kinematics=kin, transmissions=trans, drives=drives, actuators=actuators,
                            bandwidth_hz=dev["bandwidth_hz"], home_pose=home, terms=terms,
                            routing=dev["routing"])
        if kin.constraints:
            self.loop_closes(device)
        return device

    def plausible(self, kin: Kinematics, trans: tuple, drives: tuple) -> None:
        """Magnitudes a device of desktop-to-robot size cannot have, refused with the likely unit mistake
        named: a revolute limit beyond two turns, ±4π (degrees?; a multi-turn roll such as the dVRK MTM's
        ±8.7 rad stays allowed), a capstan ratio below 1 (inverted: N = motor speed /
        joint speed), a rotor inertia that peak torque accelerates at under 100 rad/s² (g·cm² or kg·cm² written
        as kg·m²?: real rotors reach 1e4–1e6 rad/s²)."""
        two_turns = 4.0 * math.pi + 1e-9
        for num, js in enumerate(kin.joints, start=1):
            if getattr(js, "sigma", 0) == 0 and js.lower is not None and js.upper is not None:
                for key in ("lower", "upper"):
                    v = getattr(js, key)
                    if abs(v) > two_turns:
                        raise self.err(f"kinematics.joints[{num}].{key}",
                                       f"{v:g} rad is beyond ±4π (two turns) for a revolute joint: degrees? "
                                       f"({v:g}° = {math.radians(v):.4g} rad)")
        for section, items in (("transmissions", trans), ("drives", drives)):
            for i, t in enumerate(items, start=1):
                if section == "drives" and t.ratio < 1.0:
                    raise self.err(f"drives[{i}].ratio", f"{t.ratio:g} < 1: a capstan reduces speed (N = motor "
                                                         f"speed / joint speed > 1); inverted? (1/{t.ratio:g} = "
                                                         f"{1.0 / t.ratio:.4g})")
                m = t.motor
                if m.rotor_inertia > 0 and m.peak_torque / m.rotor_inertia < 100.0:
                    raise self.err(f"{section}[{i}].motor.rotor_inertia",
                                   f"{m.rotor_inertia:g} kg·m² is accelerated at {m.peak_torque / m.rotor_inertia:.3g}"
                                   f" rad/s² by the peak torque {m.peak_torque:g} N·m (real rotors: 1e4–1e6): "
                                   f"g·cm²? ({m.rotor_inertia:g} g·cm² = {m.rotor_inertia * 1e-7:.3g} kg·m²)")

    def loop_closes(self, device) -> None:
        """Every cut joint's two frames coincide (within ``[kinematics] closure_tolerance``) at the mid-range pose
        and at 20 seeded poses inside the active limits: a rod written 15 mm short is refused, with the gap."""
        from .closed_loop import _closing_pairs, loop_closure_error
        from .rigid_body import tree_joint_numbers

        if not _closing_pairs(device):
            return
        tol = self.closure_tolerance
        joints = device.kinematics.joints
        active = [joints[n - 1] for n in tree_joint_numbers(device) if joints[n - 1].actuated]
        lo = np.array([j.lower for j in active], float)
        hi = np.array([j.upper for j in active], float)
        rng = np.random.default_rng(0)
        poses = [0.5 * (lo + hi)] + [rng.uniform(lo, hi) for _ in range(20)]
        worst, at = 0.0, poses[0]
        for qa in poses:
            e = loop_closure_error(device, qa).reshape(-1, 6)
            gap = float(np.linalg.norm(e[:, :3], axis=1).max())
            if gap > worst:
                worst, at = gap, qa
        if worst > tol:
            raise self.err("kinematics.constraints", f"the loop does not close: a gap of {worst * 1e3:.3g} mm between "
                                                     f"the cut joint's two frames at q_active = "
                                                     f"[{', '.join(f'{v:.3g}' for v in at)}] rad (closure_tolerance "
                                                     f"{tol:g} m): check the lengths d of the loop's rows and the "
                                                     "constraints")

    _TERM_NEEDS = {"functions": ("joint", "functions"), "polynomial": ("joint", "degree"),
                   "table": ("joint", "knots"), "spring": ("link_a", "point_a", "link_b", "point_b"),
                   "offset": ("joint",), "known": ("joint",)}

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

    def driven_joint(self, f: dict, section: str, what: str, default_prefix: str, i: int, kin: Kinematics,
                     driven_by: dict[int, int], names: dict[str, int]) -> tuple[int, str]:
        """Joint and name of entry ``i`` (0-based) of ``[[section]]``: an actuated joint of the device that no
        earlier entry drives, and a name (default ``default_prefix<joint>``) no earlier entry has."""
        path = f"{section}[{i + 1}]"
        joint = f["joint"]
        n = kin.n_joints
        if joint > n:
            raise self.no_joint(f"{path}.joint", joint, n)
        js = kin.joints[joint - 1]
        if not js.actuated:
            raise self.err(f"{path}.joint", f"joint {joint} ({js.name}) is not actuated (mu = 0)")
        if joint in driven_by:
            raise self.err(f"{path}.joint", f"joint {joint} is driven twice (also {section}[{driven_by[joint]}]); "
                                            "each joint must be driven exactly once")
        driven_by[joint] = i + 1
        name = f["name"] if f["name"] is not None else f"{default_prefix}{joint}"
        if name in names:
            raise self.err(f"{path}.name", f"duplicate {what} name {name!r} (also {section}[{names[name]}])")
        names[name] = i + 1
        return joint, name

    def motor(self, raw: Any, path: str) -> dict:
        """A [motor] table, its peak torque at least its continuous torque."""
        mot = self.table(raw, path, MOTOR_FIELDS)
        if mot["peak_torque"] < mot["continuous_torque"]:
            raise self.err(f"{path}.peak_torque", f"must be >= continuous_torque (got peak_torque = "
                                                  f"{_fmt(mot['peak_torque'])}, continuous_torque = "
                                                  f"{_fmt(mot['continuous_torque'])})")
        return mot

    def every_joint_driven(self, section: str, what: str, kin: Kinematics, driven_by: dict[int, int]) -> None:
        """Every actuated joint (cut joints aside) is driven by one entry of ``[[section]]``."""
        for num, js in enumerate(kin.joints, start=1):
            if js.actuated and js.sigma != 2 and num not in driven_by:
                raise self.err(section, f"joint {num} ({js.name}) is not driven by any {what}; each actuated "
                                        "joint must be driven exactly once")

    def actuators(self, raw: Any, kin: Kinematics) -> tuple[Actuator, ...]:
        """[[actuators]]: one geared motor per actuated joint; the coupling matrix must be invertible."""
        if not raw:
            raise self.err("actuators", "must list at least one actuator ([[actuators]])")
        driven_by: dict[int, int] = {}
        names: dict[str, int] = {}
        out = []
        n = kin.n_joints
        for i, item in enumerate(raw):
            path = f"actuators[{i + 1}]"
            f = self.table(item, path, ACTUATOR_FIELDS)
            joint, name = self.driven_joint(f, "actuators", "actuator", "motor", i, kin, driven_by, names)
            coupling = []
            if f["coupling"] is not None:
                if not isinstance(f["coupling"], dict):
                    raise self.err(f"{path}.coupling", f"must be a table (got {_typename(f['coupling'])})")
                for key, coef in f["coupling"].items():
                    kp = f"{path}.coupling.{key}"
                    if not key.isdigit():
                        raise self.err(kp, "key must be a joint number (e.g. \"5\")")
                    k = int(key)
                    if k < 1 or k > n:
                        raise self.no_joint(kp, k, n)
                    if k == joint:
                        raise self.err(kp, f"the motor's own joint {joint} is set by ratio, not by coupling")
                    if not kin.joints[k - 1].actuated:
                        raise self.err(kp, f"joint {k} is not actuated (mu = 0): couple to actuated joints only")
                    if isinstance(coef, bool) or not isinstance(coef, (int, float)) or not math.isfinite(coef) \
                            or abs(coef) > 1e3:
                        raise self.err(kp, f"must be a finite number with |x| <= 1000 (got {_fmt(coef)})")
                    coupling.append((k, float(coef)))
            out.append(Actuator(name=name, joint=joint, ratio=f["ratio"], coupling=tuple(sorted(coupling)),
                                encoder_offset=f["encoder_offset"], rotor_inertia=f["rotor_inertia"],
                                viscous_motor=f["viscous_motor"], coulomb_motor=f["coulomb_motor"],
                                torque_constant=f["torque_constant"]))
        self.every_joint_driven("actuators", "actuator", kin, driven_by)
        # Motor i is the file's i-th entry (never sorted by joint: a zero-diagonal coupling keeps its numbering).
        active = [num for num, js in enumerate(kin.joints, start=1) if js.actuated and js.sigma != 2]
        col = {num: k for k, num in enumerate(active)}
        G = np.zeros((len(out), len(active)))
        for r, a in enumerate(out):
            G[r, col[a.joint]] = a.ratio
            for k, coef in a.coupling:
                G[r, col[k]] += a.ratio * coef
        if np.linalg.cond(G) > 1e12:
            raise self.err("actuators", "the motor-to-joint matrix (ratios and couplings) is singular: the joint "
                                        "angles cannot be recovered from the motor angles")
        return tuple(out)

    def kinematics(self, raw: Any) -> Kinematics:
        k = self.table(raw, "kinematics", KINEMATICS_FIELDS)
        conv = k["convention"]
        g = np.array(k["gravity"])
        norm = float(np.linalg.norm(g))
        if norm > GRAVITY_MAX_NORM:
            raise self.err("kinematics.gravity", f"norm must be <= {_num(GRAVITY_MAX_NORM)} m/s^2 "
                                                 f"(got {norm:.6g})")
        urdf_path = None
        if conv == "urdf":
            if k["joints"] is not None:
                raise self.err("kinematics.joints", 'not allowed with convention = "urdf": the joints come '
                                                    "from the URDF file")
            if k["urdf"] is None:
                raise self.err("kinematics.urdf", 'missing required field: convention = "urdf" needs the '
                                                  "URDF file path")
            urdf_path = Path(k["urdf"])
            if not urdf_path.is_absolute():
                urdf_path = self.path.parent / urdf_path
            urdf_path = urdf_path.resolve()
            if not urdf_path.is_file():
                raise self.err("kinematics.urdf", f"URDF file not found: {urdf_path}")
            joints = self.urdf_joints(urdf_path)
        else:
            if k["urdf"] is not None:
                raise self.err("kinematics.urdf", f'only allowed with convention = "urdf" (got convention = '
                                                  f'"{conv}")')
            if k["joints"] is None:
                raise self.err("kinematics.joints", f"missing required field: convention = \"{conv}\" needs "
                                                    "one [[kinematics.joints]] entry per joint")
            if not k["joints"]:
                raise self.err("kinematics.joints", "must list at least one joint")
            joints = tuple(self.dh_joint(j, f"kinematics.joints[{i + 1}]", i + 1) if conv == "dh"
                           else self.mdh_joint(j, f"kinematics.joints[{i + 1}]", i + 1)
                           for i, j in enumerate(k["joints"]))
            seen: dict[str, int] = {}
            for i, j in enumerate(joints):
                if j.name in seen:
                    raise self.err(f"kinematics.joints[{i + 1}].name",
                                   f"duplicate joint name {j.name!r} (also kinematics.joints[{seen[j.name]}])")
                seen[j.name] = i + 1
        constraints = self.constraints(k["constraints"], conv, joints)
        self.closure_tolerance = float(k["closure_tolerance"])
        return Kinematics(convention=conv, gravity=_frozen_array(g, (3,)), joints=joints, urdf=urdf_path,
                          constraints=constraints)

    def constraints(self, raw: Any, conv: str, joints: tuple[JointSpec, ...]) -> tuple[Constraint, ...]:
        """Closed-loop constraints: one per passive non-cut joint (mu = 0, sigma != 2), terms on active
        joints only."""
        raw = list(raw or ())
        if raw and conv != "mdh":
            raise self.err("kinematics.constraints", f'only allowed with convention = "mdh" (got convention = '
                                                     f'"{conv}")')
        if conv != "mdh":
            return ()
        n = len(joints)
        by_joint: dict[int, int] = {}
        out = []
        for i, item in enumerate(raw):
            path = f"kinematics.constraints[{i + 1}]"
            f = self.table(item, path, CONSTRAINT_FIELDS)
            jn = f["joint"]
            if jn > n:
                raise self.no_joint(f"{path}.joint", jn, n)
            js = joints[jn - 1]
            if js.sigma == 2:
                raise self.err(f"{path}.joint", f"joint {jn} ({js.name}) is a cut joint / fixed frame "
                                                "(sigma = 2): it has no coordinate to constrain")
            if js.actuated:
                raise self.err(f"{path}.joint", f"joint {jn} ({js.name}) is actuated (mu = 1): only passive "
                                                "joints are determined by constraints")
            if jn in by_joint:
                raise self.err(f"{path}.joint", f"joint {jn} ({js.name}) is constrained twice (also "
                                                f"kinematics.constraints[{by_joint[jn]}])")
            by_joint[jn] = i + 1
            terms = []
            for key, coef in f["terms"].items():
                tpath = f"{path}.terms.{key}"
                try:
                    kn = int(key)
                except ValueError:
                    kn = None
                if kn is None or str(kn) != key.strip():
                    raise self.err(tpath, f"key must be an active joint number written as a string, e.g. \"2\" "
                                          f"(got {key!r})")
                if not 1 <= kn <= n:
                    raise self.no_joint(tpath, kn, n)
                ks = joints[kn - 1]
                if not ks.actuated or ks.sigma == 2:
                    raise self.err(tpath, f"joint {kn} ({ks.name}) is not an active joint (mu = 0): constraint "
                                          "terms are on active joints only")
                spec = FieldSpec(name=key, kind="float", unit="-", abs_max=1e3)
                terms.append((kn, self.number(coef, tpath, spec)))
            if not terms:
                raise self.err(f"{path}.terms", "must have at least one active-joint coefficient")
            out.append(Constraint(joint=jn, terms=tuple(sorted(terms)), offset=f["offset"]))
        for num, js in enumerate(joints, start=1):
            if not js.actuated and js.sigma != 2 and num not in by_joint:
                raise self.err("kinematics.constraints", f"joint {num} ({js.name}) is passive (mu = 0) and has no "
                                                         "constraint: every passive non-cut joint needs exactly "
                                                         "one [[kinematics.constraints]] entry")
        return tuple(sorted(out, key=lambda c: c.joint))

    def limits(self, lower, upper, path: str) -> None:
        if lower >= upper:
            raise self.err(f"{path}.lower", f"must be < upper (got lower = {_fmt(lower)}, upper = {_fmt(upper)})")

    def dh_joint(self, raw: dict, path: str, num: int) -> JointSpec:
        f = self.table(raw, path, DH_JOINT_FIELDS)
        self.limits(f["lower"], f["upper"], path)
        self.inertia(f["inertia"], f"{path}.inertia")
        return JointSpec(name=f["name"], lower=f["lower"], upper=f["upper"], a=f["a"], alpha=f["alpha"],
                         d=f["d"], theta_offset=f["theta_offset"], mass=f["mass"],
                         com=_frozen_array(f["com"], (3,)), inertia=_frozen_array(f["inertia"], (6,)))

    def mdh_joint(self, raw: dict, path: str, num: int) -> JointSpec:
        f = self.table(raw, path, MDH_JOINT_FIELDS)
        if f["j"] != num:
            raise self.err(f"{path}.j", f"must equal the entry's position {num} (got {f['j']}): list the "
                                        "frames in order j = 1, 2, ...")
        if f["antecedent"] >= f["j"]:
            raise self.err(f"{path}.antecedent", f"must be < j = {f['j']} (got {f['antecedent']}): a frame's "
                                                 "antecedent must come before it (0 = base)")
        fixed = f["sigma"] == 2
        if fixed and f["mu"] == 1:
            raise self.err(f"{path}.mu", "must be 0 for a cut joint / fixed frame (sigma = 2): it cannot be "
                                         "actuated")
        if not fixed:
            for key in ("lower", "upper", "mass", "com", "inertia"):
                if f[key] is None:
                    raise self.err(f"{path}.{key}", f"missing required field: needed for sigma = {f['sigma']}")
            if f["mass"] <= 0 and f["mu"] == 1:
                raise self.err(f"{path}.mass", f"must be > 0 (got {_fmt(f['mass'])}) for an actuated joint")
        if (f["lower"] is None) != (f["upper"] is None):
            missing = "upper" if f["upper"] is None else "lower"
            raise self.err(f"{path}.{missing}", "missing required field: lower and upper go together")
        if f["lower"] is not None:
            self.limits(f["lower"], f["upper"], path)
        mass = 0.0 if f["mass"] is None else f["mass"]
        com = (0.0, 0.0, 0.0) if f["com"] is None else f["com"]
        inertia = (0.0,) * 6 if f["inertia"] is None else f["inertia"]
        self.inertia(inertia, f"{path}.inertia")
        return JointSpec(name=f["name"], lower=f["lower"], upper=f["upper"], alpha=f["alpha"], d=f["d"],
                         theta_offset=f["theta_offset"], mass=mass, com=_frozen_array(com, (3,)),
                         inertia=_frozen_array(inertia, (6,)), j=f["j"], antecedent=f["antecedent"],
                         mu=f["mu"], sigma=f["sigma"], gamma=f["gamma"], b=f["b"], r=f["r"])

    def urdf_joints(self, urdf: Path) -> tuple[JointSpec, ...]:
        """The movable joints of a URDF (revolute, continuous, prismatic; mimic joints excluded), in
        depth-first order from the root link (the chain order for a serial robot)."""
        field = "kinematics.urdf"
        try:
            root = ET.parse(urdf).getroot()
        except (ET.ParseError, OSError) as exc:
            raise self.err(field, f"cannot parse URDF file {urdf}: {exc}") from None
        if root.tag != "robot":
            raise self.err(field, f"{urdf} is not a URDF file (root element <{root.tag}>, expected <robot>)")
        children: dict[str, list[ET.Element]] = {}
        child_links = set()
        for jt in root.findall("joint"):
            par, chi = jt.find("parent"), jt.find("child")
            if par is None or chi is None or not par.get("link") or not chi.get("link"):
                raise self.err(field, f"{urdf.name}: joint {jt.get('name')!r} lacks <parent link=...> or "
                                      "<child link=...>")
            children.setdefault(par.get("link"), []).append(jt)
            child_links.add(chi.get("link"))
        links = [ln.get("name") for ln in root.findall("link")]
        for ln in root.findall("link"):
            self.urdf_inertial(ln, urdf)
        roots = [ln for ln in links if ln not in child_links]
        if len(roots) != 1:
            raise self.err(field, f"{urdf.name}: expected one root link, found {len(roots)} ({', '.join(roots)})")
        out: list[JointSpec] = []
        order: list[ET.Element] = []

        visited: set[str] = set()

        def visit(link: str) -> None:  # joints leaving `link` in document order, depth first
            if link in visited:
                raise self.err(field, f"{urdf.name}: link {link!r} is reached twice (a kinematic loop)")
            visited.add(link)
            for jt in children.get(link, []):
                order.append(jt)
                visit(jt.find("child").get("link"))

        visit(roots[0])
        for jt in order:
            jtype = jt.get("type")
            if jtype not in ("revolute", "continuous", "prismatic") or jt.find("mimic") is not None:
                continue
            lower = upper = None
            lim = jt.find("limit")
            if jtype != "continuous" and lim is not None:
                try:
                    lower, upper = float(lim.get("lower", "0")), float(lim.get("upper", "0"))
                except ValueError:
                    raise self.err(field, f"{urdf.name}: joint {jt.get('name')!r} has non-numeric limits") from None
            jname = jt.get("name") or f"joint{len(out) + 1}"
            problem = name_problem(jname)
            if problem:          # a name from the URDF file: the domain of tendyn.text, as in the device file
                raise self.err(field, f"{urdf.name}: joint name {problem}")
            out.append(JointSpec(name=jname, lower=lower, upper=upper))
        if not out:
            raise self.err(field, f"{urdf.name}: no movable joint")
        return tuple(out)

    def urdf_inertial(self, link: ET.Element, urdf: Path) -> None:
        """Refuse a link's <inertial> that is not physical: a mass, origin or inertia entry that is not a finite
        number, a negative mass, an inertia that is not positive semidefinite or breaks the triangle inequality
        (Pinocchio would load `<mass value="nan">` as it is)."""
        inertial = link.find("inertial")
        if inertial is None:
            return
        where = f"kinematics.urdf: {urdf.name}: link {link.get('name')!r}"

        def numbers(elem, keys):
            try:
                vals = [float(v) for v in keys(elem)]
            except ValueError:
                vals = [math.nan]
            return vals

        mass = inertial.find("mass")
        if mass is not None:
            m = numbers(mass, lambda e: [e.get("value", "0")])[0]
            if not (math.isfinite(m) and m >= 0.0):
                raise self.err(f"{where} <mass>", f"must be a finite number >= 0 [kg] (got {mass.get('value')!r})")
        origin = inertial.find("origin")
        if origin is not None:
            vals = numbers(origin, lambda e: (e.get("xyz", "0 0 0") + " " + e.get("rpy", "0 0 0")).split())
            if not all(math.isfinite(v) for v in vals):
                raise self.err(f"{where} <inertial><origin>", "xyz and rpy must be finite numbers")
        tensor = inertial.find("inertia")
        if tensor is not None:
            keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
            vals = numbers(tensor, lambda e: [e.get(k, "0") for k in keys])
            if len(vals) != 6 or not all(math.isfinite(v) for v in vals):
                raise self.err(f"{where} <inertia>", "ixx … iyz must be finite numbers [kg m^2]")
            self.inertia(tuple(vals), f"{where} <inertia>")

    def transmissions(self, raw: Any, kin: Kinematics, routing: str = "one_per_joint") -> tuple[TransmissionSpec, ...]:
        if not raw:
            raise self.err("transmissions", "must list at least one transmission ([[transmissions]])")
        if routing == "n_plus_one":
            return self.tendons(raw, kin)
        driven_by: dict[int, tuple[int, str]] = {}
        entries, names = self.named_transmissions(raw, kin)
        out = []
        for i, (path, t) in enumerate(entries):
            if t.joint in driven_by:
                k, other = driven_by[t.joint]
                raise self.err(f"{path}.joint", f"joint {t.joint} is driven twice: by transmission {other} "
                                                f"(transmissions[{k}]) and by {t.name}; each joint must be "
                                                "driven exactly once (an antagonistic pair is one transmission "
                                                "with antagonistic = true; n + 1 tendons on n joints are "
                                                "written with [device] routing = \"n_plus_one\")")
            driven_by[t.joint] = (i + 1, t.name)
            out.append(t)
        for num, js in enumerate(kin.joints, start=1):
            if js.actuated and num not in driven_by:
                raise self.err("transmissions", f"joint {num} ({js.name}) is not driven by any transmission; "
                                                "each actuated joint must be driven exactly once")
        out = tuple(sorted(out, key=lambda t: t.joint))
        try:
            routing_checks.check_transmissions(out, kin.n_joints)
        except routing_checks.RoutingProblem as p:
            raise self.err(f"transmissions[{names[p.transmission]}]" + (f".{p.key}" if p.key else ""),
                           p.problem) from None
        return out

    def named_transmissions(self, raw: Any, kin: Kinematics) -> tuple[list, dict[str, int]]:
        """Each [[transmissions]] entry read as (path, spec), names unique; and name → its 1-based place in the
        file (errors found after sorting name the entry the user wrote)."""
        names: dict[str, int] = {}
        entries = []
        for i, item in enumerate(raw):
            path = f"transmissions[{i + 1}]"
            t = self.transmission(item, path, kin)
            if t.name in names:
                raise self.err(f"{path}.name", f"duplicate transmission name {t.name!r} "
                                               f"(also transmissions[{names[t.name]}])")
            names[t.name] = i + 1
            entries.append((path, t))
        return entries, names

    def tendons(self, raw: Any, kin: Kinematics) -> tuple[TransmissionSpec, ...]:
        """[[transmissions]] of an N+1 routing: n + 1 tendons on the n actuated joints; `joint` is the joint a
        tendon ends on (several may end on the same one); checked by routing_checks.check_tendons."""
        active = [num for num, js in enumerate(kin.joints, start=1) if js.actuated and js.sigma != 2]
        if len(active) != kin.n_joints:
            raise self.err("device.routing", "an N+1 routing needs every joint actuated (no passive joints or "
                                             "cut frames)")
        entries, names = self.named_transmissions(raw, kin)
        out = []
        for path, t in entries:
            if any(br is not None and br.count > 0 for br in t.bearings):
                raise self.err(f"{path}.bearings", f"transmission {t.name}: bearings are not modelled along N+1 "
                                                   "tendons (put their friction in the branch's τ0 and ν)")
            if t.reducer_efficiency != 1.0:
                raise self.err(f"{path}.reducer_efficiency", f"must be 1 on an N+1 tendon (got "
                                                             f"{t.reducer_efficiency:g}): transmission {t.name}: "
                                                             "reducer losses are not modelled along N+1 tendons")
            if t.antagonistic:
                raise self.err(f"{path}.antagonistic", f"transmission {t.name}: an N+1 routing is made of single "
                                                       "tendons (each pulls one way); antagonistic pairs are a 2N "
                                                       "routing (routing = \"one_per_joint\")")
            out.append(t)
        n = len(active)
        if len(out) != n + 1:
            raise self.err("transmissions", f"an N+1 routing needs n + 1 = {n + 1} tendons for its {n} actuated "
                                            f"joints, got {len(out)} [[transmissions]]")
        out = tuple(sorted(out, key=lambda t: t.joint))   # stable: tendons ending on one joint keep file order
        try:
            routing_checks.check_tendons(out, n)
        except routing_checks.RoutingProblem as p:
            where = f"transmissions[{names[p.transmission]}]" if p.transmission in names else "transmissions"
            raise self.err(where + (f".{p.key}" if p.key else ""), p.problem) from None
        return out

    def transmission(self, raw: dict, path: str, kin: Kinematics) -> TransmissionSpec:
        f = self.table(raw, path, TRANSMISSION_FIELDS)
        name, joint = f["name"], f["joint"]
        n = kin.n_joints
        if joint > n:
            raise self.no_joint(f"{path}.joint", joint, n)
        js = kin.joints[joint - 1]
        if not js.actuated:
            raise self.err(f"{path}.joint", f"joint {joint} ({js.name}) is not actuated (mu = 0)")
        crosses, radii = f["crosses"], f["crossed_radii"]
        seen = set()
        for k, c in enumerate(crosses):
            cp = f"{path}.crosses[{k + 1}]"
            if c < 1:
                raise self.err(cp, f"must be a joint number >= 1 (got {c})")
            if c > n:
                raise self.no_joint(cp, c, n)
            if c == joint:
                raise self.err(cp, f"joint {c} is the joint transmission {name} drives: its radius there is "
                                   "driven_radius, not a crossed radius")
            if c in seen:
                raise self.err(cp, f"joint {c} is listed twice")
            seen.add(c)
        if len(radii) != len(crosses):
            raise self.err(f"{path}.crossed_radii", f"must have one radius per crossed joint: crosses has "
                                                    f"{len(crosses)} entries, crossed_radii has {len(radii)}")
        # friction: one entry per branch, up to the last joint the cable wraps (past `joint` for a differential)
        last = max((joint, *crosses))
        fr_raw = f["friction"]
        if len(fr_raw) != last:
            why = (f"transmission {name} drives joint {joint}" if last == joint else
                   f"transmission {name} wraps joints up to {last}")
            raise self.err(f"{path}.friction", f"must have exactly {last} entries, one per branch "
                                               f"({why}), got {len(fr_raw)}")
        friction = tuple(BranchFriction(**self.table(e, f"{path}.friction[{b + 1}]", FRICTION_FIELDS))
                         for b, e in enumerate(fr_raw))
        br_raw = f["bearings"]
        if br_raw is None:
            bearings: tuple = (None,) * last
        else:
            if len(br_raw) != len(fr_raw):
                raise self.err(f"{path}.bearings", f"must have the same length as friction ({len(fr_raw)}, one "
                                                   f"per branch), got {len(br_raw)}; use {{}} for none")
            bearings = tuple(None if not e else Bearing(**self.table(e, f"{path}.bearings[{b + 1}]",
                                                                      BEARING_FIELDS))
                             for b, e in enumerate(br_raw))
        if last > joint and (f["reducer_ratio"] != 1.0 or f["reducer_efficiency"] != 1.0):
            key = "reducer_ratio" if f["reducer_ratio"] != 1.0 else "reducer_efficiency"
            raise self.err(f"{path}.{key}", f"must be 1 (got {_fmt(f[key])}): transmission {name} wraps joint "
                                            f"{last} after the joint it drives ({joint}), a differential whose "
                                            "driven pulley holds no reducer (put the ratio in the radii)")
        if f["antagonistic"] and any(b is not None and b.count > 0 for b in bearings):
            raise self.err(f"{path}.bearings", f"transmission {name} is an antagonistic pair: bearings on a pair "
                                               "are not modelled (their load is the sum of both cables' tensions)")
        mot = self.motor(f["motor"], f"{path}.motor")
        sen = self.table(f["sensors"], f"{path}.sensors", SENSOR_FIELDS)
        return TransmissionSpec(
            name=name, joint=joint, motor_radius=f["motor_radius"], crosses=tuple(crosses),
            crossed_radii=tuple(radii), driven_radius=f["driven_radius"], reducer_ratio=f["reducer_ratio"],
            reducer_efficiency=f["reducer_efficiency"], pretension=f["pretension"], friction=friction,
            bearings=bearings, motor=Motor(**mot), sensors=Sensors(**sen), antagonistic=f["antagonistic"])

    def drives(self, raw: Any, kin: Kinematics) -> tuple[Drive, ...]:
        if not raw:
            raise self.err("drives", "must list at least one drive ([[drives]])")
        driven_by: dict[int, int] = {}
        names: dict[str, int] = {}
        out = []
        for i, item in enumerate(raw):
            path = f"drives[{i + 1}]"
            f = self.table(item, path, DRIVE_FIELDS)
            joint, name = self.driven_joint(f, "drives", "drive", "drive", i, kin, driven_by, names)
            mot = self.motor(f["motor"], f"{path}.motor")
            sen = self.table(f["sensors"], f"{path}.sensors", SENSOR_FIELDS)
            out.append(Drive(name=name, joint=joint, ratio=f["ratio"], stiffness_motor=f["stiffness_motor"],
                             damping_motor=f["damping_motor"], coulomb_motor=f["coulomb_motor"],
                             viscous_motor=f["viscous_motor"], offset_joint=f["offset_joint"],
                             motor=Motor(**mot), sensors=Sensors(**sen),
                             servo_stiffness_motor=f["servo_stiffness_motor"]))
        self.every_joint_driven("drives", "drive", kin, driven_by)
        return tuple(sorted(out, key=lambda d: d.joint))
