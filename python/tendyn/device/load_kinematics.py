"""Reading a device file, the kinematics: the convention (DH, modified DH, URDF), the joints and their
limits, the links' inertias from a URDF, and the closed-loop constraints."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from tendyn.text import name_problem

from .load_fields import _fmt, _FieldReader
from .schema_fields import (CONSTRAINT_FIELDS, DH_JOINT_FIELDS, GRAVITY_MAX_NORM, KINEMATICS_FIELDS, MDH_JOINT_FIELDS,
                            FieldSpec, _num)
from .schema_parts import Constraint, JointSpec, Kinematics, _frozen_array


class _KinematicsReader(_FieldReader):
    """The [kinematics] section of a device file."""

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
