"""Rigid-body chain of a device: joint frames from its kinematic description, and the C++ model.

Standard DH (a, α, d, θ): ᵢ₋₁Tᵢ = Rz(θ) Tz(d) Tx(a) Rx(α), joint i turns about z_{i−1}.
Pinocchio wants, per joint, the placement of its (unmoved) frame in the parent joint frame and
the link inertia in its own frame; for standard DH joint i sits on frame i−1, so its placement is
the constant part of link i−1 and link i's inertia is moved from frame i by that constant part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def rot_x(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_z(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def dh_transform(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Standard DH link transform ᵢ₋₁Tᵢ = Rz(θ) Tz(d) Tx(a) Rx(α) (lengths [m], angles [rad])."""
    return rot_z(theta) @ trans(z=d) @ trans(x=a) @ rot_x(alpha)


def mdh_transform(gamma: float, b: float, alpha: float, d: float, theta: float, r: float) -> np.ndarray:
    """Khalil–Kleinfinger modified DH: Rz(γ) Tz(b) Rx(α) Tx(d) Rz(θ) Tz(r)."""
    return rot_z(gamma) @ trans(z=b) @ rot_x(alpha) @ trans(x=d) @ rot_z(theta) @ trans(z=r)


def inertia_matrix(six) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] → symmetric 3×3 [kg·m²]."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(v) for v in six)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


@dataclass(frozen=True)
class JointFrame:
    """One joint of the chain as Pinocchio takes it (all in the joint's own frame)."""

    name: str
    parent: int               # parent joint index, 0 = base
    placement: np.ndarray     # (4, 4) joint frame in the parent joint frame at q = 0
    axis: np.ndarray          # (3,) unit axis of motion in the joint frame
    prismatic: bool
    mass: float               # [kg]
    com: np.ndarray           # (3,) [m] in the joint frame
    inertia: np.ndarray       # (3, 3) [kg·m²] about the COM, joint-frame axes


def _mdh_constant(js) -> np.ndarray:
    """Constant part of the KK transform of an mdh row: Rz(γ) Tz(b) Rx(α) Tx(d) Rz(θ₀) Tz(r₀).

    For a revolute joint θ = q + θ₀ and Rz(q) commutes with Tz(r), so frame j = constant · Rz(q); for a
    prismatic joint r = q + r₀ and frame j = constant · Tz(q); a cut joint / fixed frame (σ = 2) is the
    constant part alone.
    """
    return mdh_transform(js.gamma or 0.0, js.b or 0.0, js.alpha, js.d, js.theta_offset or 0.0, js.r or 0.0)


def _mdh_tree(device):
    """Resolve the mdh rows into (tree index or None, parent tree index, placement in the parent joint frame).

    Rows with σ = 2 are fixed frames (cut joints close loops): they get no tree index; a row whose
    antecedent is a fixed frame is placed through it.
    """
    kin = device.kinematics
    tree_index: dict[int, int] = {}            # file frame number -> 1-based Pinocchio joint index
    anchor: dict[int, tuple[int, np.ndarray]] = {0: (0, np.eye(4))}  # frame -> (tree parent, placement)
    rows = []
    for num, js in enumerate(kin.joints, start=1):
        a = int(js.antecedent)
        if a in tree_index:
            parent, pre = tree_index[a], np.eye(4)
        else:
            parent, pre = anchor[a]
        placement = pre @ _mdh_constant(js)
        if js.sigma == 2:
            anchor[num] = (parent, placement)
            rows.append((None, parent, placement))
        else:
            tree_index[num] = len(tree_index) + 1
            rows.append((tree_index[num], parent, placement))
    return rows


def tree_joint_numbers(device) -> list[int]:
    """File joint numbers (1-based) of the joints of the rigid-body tree, in tree order (σ = 2 rows skipped)."""
    kin = device.kinematics
    if kin.convention != "mdh":
        return list(range(1, kin.n_joints + 1))
    return [num for num, js in enumerate(kin.joints, start=1) if js.sigma != 2]


def joint_frames(device) -> list[JointFrame]:
    """Joint frames of the rigid-body tree of a device.

    Convention "dh": open chain, standard DH. Convention "mdh" (Khalil–Kleinfinger): frame j relative to
    its antecedent a(j) is Rz(γ) Tz(b) Rx(α) Tx(d) Rz(θ) Tz(r), θ = q + theta_offset (revolute) or
    r = q + r (prismatic); the Pinocchio joint frame is frame j itself, so ``com`` and ``inertia`` (about the
    COM, frame-j axes) pass unchanged. Cut joints / fixed frames (σ = 2) are not in the tree (see
    :func:`cut_frames`); ``parent`` is the 1-based index among the tree joints (0 = base), not the file's
    antecedent number.
    """
    kin = device.kinematics
    frames: list[JointFrame] = []
    if kin.convention == "dh":
        previous_link = np.eye(4)  # constant part of link i−1 (identity for the base)
        for js in kin.joints:
            link = rot_z(js.theta_offset) @ trans(z=js.d) @ trans(x=js.a) @ rot_x(js.alpha)
            R = link[:3, :3]
            frames.append(JointFrame(
                js.name, len(frames), previous_link, np.array([0.0, 0.0, 1.0]), False,
                float(js.mass), link[:3, :3] @ np.asarray(js.com, float) + link[:3, 3],
                R @ inertia_matrix(js.inertia) @ R.T))
            previous_link = link
        return frames
    if kin.convention == "mdh":
        for js, (idx, parent, placement) in zip(kin.joints, _mdh_tree(device)):
            if idx is None:
                continue
            frames.append(JointFrame(
                js.name, parent, placement, np.array([0.0, 0.0, 1.0]), js.sigma == 1,
                float(js.mass or 0.0), np.asarray(js.com if js.com is not None else (0, 0, 0), float),
                inertia_matrix(js.inertia if js.inertia is not None else (0,) * 6)))
        return frames
    if kin.convention == "urdf":
        return _urdf_frames(device)
    raise NotImplementedError(f"rigid-body model for convention {kin.convention!r} is not built yet")


def link_point_in_joint_frame(device, number: int, p) -> np.ndarray:
    """A point [m] given in the frame of link ``number`` as the device file gives a ``com`` (standard DH: frame
    i; mdh: frame j; URDF: the child link frame), expressed in the Pinocchio joint frame of that link (the
    transform :func:`joint_frames` applies to the COM)."""
    kin = device.kinematics
    p = np.asarray(p, float)
    if kin.convention != "dh":
        return p
    js = kin.joints[number - 1]
    link = rot_z(js.theta_offset) @ trans(z=js.d) @ trans(x=js.a) @ rot_x(js.alpha)
    return link[:3, :3] @ p + link[:3, 3]


_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def _urdf_frames(device) -> list[JointFrame]:
    """Joint frames of a URDF tree, read by Pinocchio's URDF parser (fixed joints merged into their
    parent bodies by Pinocchio). One-DOF revolute/prismatic joints only: a continuous joint (two
    coordinates in Pinocchio) or a floating base is refused with a clear message."""
    import pinocchio as pin

    from tendyn.device.base import DeviceError

    path = str(device.kinematics.urdf)
    try:
        model = pin.buildModelFromUrdf(path)
    except Exception as exc:  # noqa: BLE001 — Pinocchio raises plain RuntimeError/ValueError
        raise DeviceError(f"Pinocchio cannot build a model from {path}: {exc}",
                          file=str(device.path), field="kinematics.urdf") from None
    frames = []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        short = joint.shortname()
        if joint.nq != 1 or joint.nv != 1:
            raise DeviceError(f"joint {model.names[jid]!r} is a {short} with {joint.nq} coordinates; only one-DOF "
                              "revolute or prismatic joints are supported (write a continuous joint as revolute "
                              "with wide limits)", file=str(device.path), field="kinematics.urdf")
        prismatic = short.startswith("JointModelP")
        if short[-1] in _AXES and ("JointModelR" in short or "JointModelP" in short) and "Unaligned" not in short:
            axis = np.array(_AXES[short[-1]])
        else:
            axis = np.asarray(joint.extract().axis, float)
        inertia = model.inertias[jid]
        frames.append(JointFrame(model.names[jid], int(model.parents[jid]), model.jointPlacements[jid].homogeneous,
                                 axis, prismatic, float(inertia.mass), np.array(inertia.lever),
                                 np.array(inertia.inertia)))
    return frames


@dataclass(frozen=True)
class CutFrame:
    """A fixed frame (σ = 2 row of an mdh table, e.g. the far side of a cut joint)."""

    name: str
    number: int               # file frame number j (1-based)
    antecedent: int           # file frame number a(j)
    parent: int               # 1-based tree joint the frame is fixed to (0 = base)
    placement: np.ndarray     # (4, 4) frame in that tree joint's frame


def cut_frames(device) -> list[CutFrame]:
    """The σ = 2 frames of an mdh device (not part of the tree), for loop-closure checks."""
    kin = device.kinematics
    if kin.convention != "mdh":
        return []
    return [CutFrame(js.name, num, int(js.antecedent), parent, placement)
            for num, (js, (idx, parent, placement)) in enumerate(zip(kin.joints, _mdh_tree(device)), start=1)
            if idx is None]


def pinocchio_model(device, frames: list[JointFrame] | None = None):
    """A new Python Pinocchio model (``pin.Model``) of the device's rigid-body tree (gravity from the device).

    Joint k of the model (1-based) is ``joint_frames(device)[k - 1]``; its q/v index is k − 1. ``frames``
    are the device's :func:`joint_frames` when the caller has them already. Experiments and estimators use
    the one model of :func:`tendyn.device.compile_device` instead of building their own.
    """
    import pinocchio as pin

    model = pin.Model()
    model.gravity.linear = np.asarray(device.kinematics.gravity, float)
    for f in (joint_frames(device) if frames is None else frames):
        z = np.allclose(f.axis, (0.0, 0.0, 1.0))
        if f.prismatic:
            jm = pin.JointModelPZ() if z else pin.JointModelPrismaticUnaligned(np.asarray(f.axis, float))
        else:
            jm = pin.JointModelRZ() if z else pin.JointModelRevoluteUnaligned(np.asarray(f.axis, float))
        jid = model.addJoint(f.parent, jm, pin.SE3(f.placement[:3, :3].copy(), f.placement[:3, 3].copy()), f.name)
        model.appendBodyToJoint(jid, pin.Inertia(f.mass, np.asarray(f.com, float), np.asarray(f.inertia, float)),
                                pin.SE3.Identity())
    return model


STANDARD_PARAMETER_NAMES = ("M", "MX", "MY", "MZ", "XX", "XY", "YY", "XZ", "YZ", "ZZ")
"""The 10 standard (classical) parameters of a link in Pinocchio's order: mass [kg], first moments
[kg·m] and inertia [kg·m²] about the link frame's origin, link-frame axes (S2 section II)."""


UNITS = {"XX": "kg·m²", "XY": "kg·m²", "XZ": "kg·m²", "YY": "kg·m²", "YZ": "kg·m²", "ZZ": "kg·m²",
         "MX": "kg·m", "MY": "kg·m", "MZ": "kg·m", "M": "kg", "IA": "kg·m²", "FV": "N·m·s/rad", "FS": "N·m",
         "OFFSET": "N·m", "IAm": "kg·m² (motor side)", "FVm": "N·m·s/rad (motor side)",
         "FSm": "N·m (motor side)"}
"""Units of the standard (and drive) parameters by stem; a base parameter has the unit of its stem."""


def unit_of(name: str) -> str:
    """The unit of a standard or base parameter name (``ZZ1R`` → kg·m²)."""
    stem = name
    while stem and (stem[-1].isdigit() or stem[-1] == "R"):
        stem = stem[:-1]
    return UNITS.get(stem, "")


def standard_parameters(device) -> tuple[list[str], np.ndarray]:
    """Names (``"ZZ2"``: parameter + file joint number) and values of the standard parameters of the tree.

    The file stores mass m, COM c and inertia I_c about the COM; about the frame origin
    MS = m c and J_O = I_c + m (cᵀc 1 − c cᵀ) (parallel-axis theorem).
    """
    names, values = [], []
    for num, f in zip(tree_joint_numbers(device), joint_frames(device)):
        c = np.asarray(f.com, float)
        J = np.asarray(f.inertia, float) + f.mass * (c @ c * np.eye(3) - np.outer(c, c))
        ms = f.mass * c
        values += [f.mass, ms[0], ms[1], ms[2], J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]]
        names += [f"{p}{num}" for p in STANDARD_PARAMETER_NAMES]
    return names, np.array(values)


def rigid_body_model(device, frames: list[JointFrame] | None = None):
    """A new C++ rigid-body model (:class:`tendyn._core.RigidBodyModel`) of a device's chain (``frames``:
    its :func:`joint_frames`, if already computed)."""
    from tendyn import _core

    model = _core.RigidBodyModel()
    model.set_gravity(np.asarray(device.kinematics.gravity, float))
    for f in (joint_frames(device) if frames is None else frames):
        model.add_joint(f.parent, f.placement, f.axis, f.prismatic, f.mass, f.com, f.inertia, f.name)
    return model


def dh_forward_kinematics(device, q) -> list[np.ndarray]:
    """Base-frame transforms of DH frames 0…n at joint positions q [rad] (standard DH only).

    Written directly from the DH table, independently of :func:`joint_frames`, so it can serve as
    an oracle for the Pinocchio route.
    """
    T = np.eye(4)
    out = [T]
    for js, qi in zip(device.kinematics.joints, np.asarray(q, float)):
        T = T @ dh_transform(js.a, js.alpha, js.d, qi + js.theta_offset)
        out.append(T)
    return out


def active_coordinate_map(device) -> tuple[list[int], np.ndarray, np.ndarray]:
    """The linear map from active to tree coordinates, q_tree = L q_active + c.

    Parameters
    ----------
    device : Device
        A loaded device ("dh" or "mdh"; constraints only for "mdh").

    Returns
    -------
    active : list of int
        0-based tree indices of the active (mu = 1) joints, in tree order.
    L : ndarray, shape (n_tree, n_active)
        ∂q_tree/∂q_active [-]: identity rows for active joints, the constraint coefficients for passive ones.
    c : ndarray, shape (n_tree,)
        Constant offsets [rad] (or [m]) of the constraints; 0 for active joints.

    For a serial device (no passive joints) L = I and c = 0. Kinematics of the description only, so the compiled
    device (``CompiledDevice.active_map``) and :mod:`tendyn.device.closed_loop` read it from here.
    """
    kin = device.kinematics
    numbers = tree_joint_numbers(device)
    pos = {num: k for k, num in enumerate(numbers)}
    joints = kin.joints
    active = [k for k, num in enumerate(numbers) if joints[num - 1].actuated]
    col = {numbers[k]: i for i, k in enumerate(active)}
    L = np.zeros((len(numbers), len(active)))
    c = np.zeros(len(numbers))
    for num in col:
        L[pos[num], col[num]] = 1.0
    constrained = set()
    for con in getattr(kin, "constraints", ()):
        row = pos[con.joint]
        for jn, coef in con.terms:
            L[row, col[jn]] += coef
        c[row] = con.offset
        constrained.add(con.joint)
    missing = [num for num in numbers if num not in col and num not in constrained]
    if missing:
        raise ValueError(f"passive joints without a constraint: {missing}")
    return active, L, c
