"""One compensator cycle (velocity estimate + gravity + losses) written with numpy: benchmark baseline.

Same physics as include/tendyn/compensator.hpp: filtered difference, q = K⁻¹ R_m q_m, gravity
g = −Σ_k J_com,kᵀ m_k g⃗ from homogeneous transforms, statics with losses (numpy_statics), k and the band.
"""

import numpy as np

from numpy_statics import motor_torque_feedforward


class NumpyCompensator:
    def __init__(self, arr, frames, gravity, k, band, alpha, rate):
        self.arr = arr
        K, r_m = arr["K"], arr["motor_radius"]
        self.Jm2j = np.linalg.solve(K, np.diag(r_m))
        self.Mt = np.diag(r_m) @ np.linalg.inv(K).T
        self.placement = [np.asarray(f.placement, float) for f in frames]
        self.com = [np.asarray(f.com, float) for f in frames]
        self.mass = np.array([f.mass for f in frames])
        self.g = np.asarray(gravity, float)
        self.k, self.band, self.alpha, self.rate = k, band, alpha, rate
        self.prev = None
        self.qdm = np.zeros(r_m.size)

    def cycle(self, qm, tau_wanted):
        if self.prev is None:
            self.prev = qm.copy()
        self.qdm = self.qdm + self.alpha * ((qm - self.prev) * self.rate - self.qdm)
        self.prev = qm.copy()
        q, qd = self.Jm2j @ qm, self.Jm2j @ self.qdm
        n = q.size
        T, acc = [], np.eye(4)
        for j in range(n):
            c, s = np.cos(q[j]), np.sin(q[j])
            rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
            acc = acc @ self.placement[j] @ rz
            T.append(acc)
        grav = np.zeros(n)
        for kk in range(n):
            com = T[kk][:3, :3] @ self.com[kk] + T[kk][:3, 3]
            for j in range(kk + 1):
                grav[j] -= np.cross(T[j][:3, 2], com - T[j][:3, 3]) @ (self.mass[kk] * self.g)
        tau = tau_wanted + grav
        c0 = self.Mt @ tau
        cff = motor_torque_feedforward(self.arr, tau, qd)
        w = np.minimum(1.0, np.abs(self.qdm) / self.band) if self.band > 0 else np.ones(n)
        return c0 + self.k * w * (cff - c0)
