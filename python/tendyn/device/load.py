"""Read and validate a device file (TOML, schema version 1).

:func:`load_device` is the only entry point. Every problem a user can cause raises one
:class:`~tendyn.device.schema.DeviceError` whose message names the file, the field path (array entries
counted from 1, as joints and transmissions are numbered in the file) and what is wrong; the first problem
found is reported.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ._toml import read_toml, typename as _typename
from .base import Device
from .load_actuation import _ActuationReader
from .load_kinematics import _KinematicsReader
from .load_terms import _TermsReader
from .schema_fields import DEVICE_FIELDS, SCHEMA_VERSION, TOP_FIELDS
from .schema_parts import Kinematics
from .serial_device import SerialDevice
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


class _Parser(_KinematicsReader, _ActuationReader, _TermsReader):
    """Walks the parsed TOML dict; knows the file for the messages. The generic values are read by
    :mod:`~tendyn.device.load_fields`, the sections by :mod:`~tendyn.device.load_kinematics`,
    :mod:`~tendyn.device.load_actuation` and :mod:`~tendyn.device.load_terms`; the device as a whole here."""

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
