"""The C++ core links Pinocchio: gravity torques computed in C++ against Pinocchio's Python rnea
and against finite differences of the potential energy written from the DH table."""

from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from tendyn import _core
from tendyn.device.rigid_body import dh_forward_kinematics, pinocchio_model, rigid_body_model


def random_dh_device(rng, n):
    joints = []
    for i in range(n):
        A = rng.normal(size=(3, 3))
        principal = rng.uniform(0.002, 0.02, 3)
        principal[2] = min(principal[2], principal[0] + principal[1])  # triangle inequality
        Q, _ = np.linalg.qr(A)
        I = Q @ np.diag(principal) @ Q.T
        joints.append(SimpleNamespace(
            name=f"j{i + 1}", a=rng.uniform(-0.3, 0.3), alpha=rng.uniform(-np.pi, np.pi),
            d=rng.uniform(-0.3, 0.3), theta_offset=rng.uniform(-1, 1), mass=rng.uniform(0.2, 3),
            com=rng.uniform(-0.2, 0.2, 3), inertia=[I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
    g = rng.normal(size=3)
    g *= 9.81 / np.linalg.norm(g)
    return SimpleNamespace(kinematics=SimpleNamespace(convention="dh", gravity=g, joints=tuple(joints)))


def potential_energy(device, q):
    frames = dh_forward_kinematics(device, q)
    g = np.asarray(device.kinematics.gravity, float)
    V = 0.0
    for js, T in zip(device.kinematics.joints, frames[1:]):
        p = T[:3, :3] @ np.asarray(js.com, float) + T[:3, 3]
        V -= js.mass * g @ p
    return V


def test_cpp_gravity_matches_python_pinocchio_and_energy(rng):
    for _ in range(30):
        n = int(rng.integers(1, 7))
        dev = random_dh_device(rng, n)
        cpp = rigid_body_model(dev)
        data = _core.RigidBodyData(cpp)
        py = pinocchio_model(dev)
        pdata = py.createData()
        for _ in range(5):
            q = rng.uniform(-np.pi, np.pi, n)
            _core.gravity_torque(cpp, data, q)
            g_cpp = np.array(data.gravity_torque)
            g_py = pin.rnea(py, pdata, q, np.zeros(n), np.zeros(n))
            np.testing.assert_allclose(g_cpp, g_py, rtol=1e-12, atol=1e-12)
            h = 1e-6
            g_fd = np.array([(potential_energy(dev, q + h * e) - potential_energy(dev, q - h * e)) / (2 * h)
                             for e in np.eye(n)])
            np.testing.assert_allclose(g_cpp, g_fd, rtol=1e-6, atol=1e-7)
