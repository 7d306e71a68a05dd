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


def joint_frames(device) -> list[JointFrame]:
    """Joint frames of an open chain described by standard DH (convention "dh") or KK ("mdh")."""
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
        for js in kin.joints:
            if js.sigma == 2:
                raise NotImplementedError("cut joints (sigma = 2) need the closed-loop builder")
            placement = mdh_transform(js.gamma, js.b, js.alpha, js.d,
                                      js.theta_offset if js.sigma == 0 else js.theta_offset,
                                      js.r if js.sigma == 0 else js.r)
            frames.append(JointFrame(
                js.name, int(js.antecedent), placement, np.array([0.0, 0.0, 1.0]), js.sigma == 1,
                float(js.mass or 0.0), np.asarray(js.com if js.com is not None else (0, 0, 0), float),
                inertia_matrix(js.inertia if js.inertia is not None else (0,) * 6)))
        return frames
    raise NotImplementedError(f"rigid-body model for convention {kin.convention!r} is not built yet")


def rigid_body_model(device):
    """The C++ rigid-body model (:class:`tendyn._core.RigidBodyModel`) of a device's chain."""
    from tendyn import _core

    model = _core.RigidBodyModel()
    model.set_gravity(np.asarray(device.kinematics.gravity, float))
    for f in joint_frames(device):
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
