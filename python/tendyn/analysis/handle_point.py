"""The handle point of a serial device: its position, Jacobian and J̇q̇ in the operator frame, the joint limits
and an inverse kinematics that stays on one branch.

One place for the kinematics every map at the handle needs (the capstan branch of S2,
:mod:`tendyn.analysis.operational`, and cable devices, :mod:`tendyn.analysis.handle_maps`). The handle is
:func:`tendyn.device.closed_loop.end_effector_point`, added as a frame on a copy of the device's Pinocchio
tree; active coordinates map to the tree as q_tree = L q_a + c. The operator frame has its z axis against
gravity and its x axis the horizontal part of the base x axis (y = z × x); without gravity it is the base frame.
"""

from __future__ import annotations

import math

import numpy as np

from tendyn.device import compile_device

__all__ = ["HandlePoint"]


class HandlePoint:
    """Kinematics of the end-effector point of a serial device (active coordinates, operator frame).

    Parameters
    ----------
    device : Device or CompiledDevice (``kind == "serial"``)

    Attributes
    ----------
    frame : (3, 3) base ← operator rotation [-]
    L, c : the active map q_tree = L q_a + c
    active_numbers : 1-based file numbers of the active joints, in tree order
    """

    def __init__(self, device):
        import pinocchio as pin

        from tendyn.device.closed_loop import end_effector_point
        from tendyn.device.rigid_body import tree_joint_numbers

        self.compiled = compile_device(device)
        dev = self.compiled.device
        self.device = dev
        numbers = tree_joint_numbers(dev)
        self.active_numbers = [numbers[k] for k in self.compiled.active_joints]
        L, c = self.compiled.active_map
        self.L, self.c = np.asarray(L), np.asarray(c)
        joint, point = end_effector_point(self.compiled)
        self._pin = pin
        self._model = pin.Model(self.compiled.pinocchio_model)
        self._frame = self._model.addFrame(pin.Frame("handle", joint + 1, 0, pin.SE3(np.eye(3), np.asarray(point)),
                                                     pin.FrameType.OP_FRAME))
        self._data = self._model.createData()
        g = np.asarray(dev.kinematics.gravity, float)
        up = -g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 0.0, 1.0])
        ex = np.array([1.0, 0.0, 0.0]) - up[0] * up
        if np.linalg.norm(ex) < 1e-6:
            ex = np.array([0.0, 1.0, 0.0]) - up[1] * up
        ex /= np.linalg.norm(ex)
        self.frame = np.column_stack([ex, np.cross(up, ex), up])   # base ← operator
        joints = dev.kinematics.joints
        lo, hi = [], []
        for num in numbers:
            js = joints[num - 1]
            lo.append(-np.inf if js.lower is None else js.lower)
            hi.append(np.inf if js.upper is None else js.upper)
        self._limits = np.array(lo), np.array(hi)

    @property
    def n_active(self) -> int:
        return self.L.shape[1]

    def tree(self, qa) -> np.ndarray:
        """q_tree = L q_a + c [rad]."""
        return self.L @ np.asarray(qa, float) + self.c

    def active_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of the active joints [rad] (±inf where the file gives none)."""
        joints = self.device.kinematics.joints
        lo = np.array([-np.inf if joints[j - 1].lower is None else joints[j - 1].lower for j in self.active_numbers])
        hi = np.array([np.inf if joints[j - 1].upper is None else joints[j - 1].upper for j in self.active_numbers])
        return lo, hi

    def position(self, qa) -> np.ndarray:
        """Handle position [m], operator frame (origin: the base origin)."""
        pin = self._pin
        pin.framesForwardKinematics(self._model, self._data, self.tree(qa))
        return self.frame.T @ np.array(self._data.oMf[self._frame].translation)

    def jacobian(self, qa) -> np.ndarray:
        """J = ∂X/∂q_a [m/rad] (3 × n_active), operator frame: the tree's frame Jacobian times L."""
        pin = self._pin
        pin.computeJointJacobians(self._model, self._data, self.tree(qa))
        pin.updateFramePlacements(self._model, self._data)
        J = pin.getFrameJacobian(self._model, self._data, self._frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        J = np.asarray(J).reshape(6, self._model.nv)[:3]      # a one-joint tree comes back as a vector
        return self.frame.T @ J @ self.L

    def jdot_qd(self, qa, qd) -> np.ndarray:
        """J̇ q̇ [m/s²], operator frame: the classical acceleration of the handle point at q̈ = 0."""
        pin = self._pin
        v = self.L @ np.asarray(qd, float)
        pin.forwardKinematics(self._model, self._data, self.tree(qa), v, np.zeros_like(v))
        pin.updateFramePlacements(self._model, self._data)
        a = pin.getFrameClassicalAcceleration(self._model, self._data, self._frame,
                                              pin.ReferenceFrame.LOCAL_WORLD_ALIGNED).linear
        return self.frame.T @ np.asarray(a)

    def within_limits(self, qa, margin: float = 0.0) -> bool:
        """Every tree joint (active and passive, q_tree = L q_a + c) inside its limits [rad]."""
        q = self.tree(qa)
        lo, hi = self._limits
        return bool(np.all(q >= lo + margin) and np.all(q <= hi - margin))

    def inverse_kinematics(self, x, q_start, step: float = 0.01, tol: float = 1e-10):
        """Active joints [rad] putting the handle at x [m] (operator frame), by Newton steps along the straight
        path from the handle position at q_start (continuation, at most ``step`` [m] per leg, so the solution
        stays on q_start's branch). Square Jacobians only; None when it does not converge or crosses a
        singularity."""
        q = np.array(q_start, float)
        x0 = self.position(q)
        x = np.asarray(x, float)
        legs = max(1, int(math.ceil(np.linalg.norm(x - x0) / step)))
        for k in range(1, legs + 1):
            target = x0 + (x - x0) * k / legs
            for _ in range(25):
                e = target - self.position(q)
                if np.linalg.norm(e) < tol:
                    break
                J = self.jacobian(q)
                if np.linalg.cond(J) > 1e6:
                    return None
                q = q + np.linalg.solve(J, e)
            else:
                return None
        return q
