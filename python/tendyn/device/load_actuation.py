"""Reading a device file, what moves the joints: cable transmissions (one per joint, or N+1 tendons), capstan
drives, their motors and sensors, and the actuators that couple motors to joints."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import routing_checks
from ._toml import typename as _typename
from .load_fields import _fmt, _FieldReader
from .schema_fields import (ACTUATOR_FIELDS, BEARING_FIELDS, DRIVE_FIELDS, FRICTION_FIELDS, MOTOR_FIELDS,
                            SENSOR_FIELDS, TRANSMISSION_FIELDS)
from .schema_parts import Actuator, Bearing, BranchFriction, Drive, Kinematics, Motor, Sensors, TransmissionSpec


class _ActuationReader(_FieldReader):
    """The [[transmissions]], [[drives]] and [[actuators]] sections of a device file."""

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
