"""The feedforward statics recursion written with numpy: benchmark baseline and test oracle.

Same physics as include/tendyn/losses.hpp (S0 eqs. 4, 6, 9–12 corrected), without bearings.
"""

import numpy as np


def _upstream(x, sdot, a, b, nu):
    s = 1.0 if sdot > 0 else -1.0
    ax, sb = abs(x), s * b
    c = x + s * a + nu * sdot
    if c < -ax * (1 + sb):
        return c / (1 + sb)
    if c <= ax * (1 - sb):
        return c + sb * ax
    return c / (1 - sb)


def motor_torque_feedforward(arr, torque_joint, qd):
    """arr: routing arrays (motor_radius, K, driven_radius, reducer_ratio, reducer_efficiency, tau0, nu, beta)."""
    K = arr["K"]
    r_m = arr["motor_radius"]
    n = r_m.size
    qd_motor = (K @ qd) / r_m
    Sdot = np.zeros((n, n))
    for i in range(n):
        Sdot[i, 0] = r_m[i] * qd_motor[i]
        for b in range(1, i + 1):
            Sdot[i, b] = Sdot[i, b - 1] - K[i, b - 1] * qd[b - 1]
    T = np.zeros((n, n))
    Cm = np.zeros(n)
    for i in range(n - 1, -1, -1):
        own = torque_joint[i] - K[i + 1:, i] @ T[i + 1:, i]
        ratio, eta = arr["reducer_ratio"][i], arr["reducer_efficiency"][i]
        p = own * qd[i]
        pulley = own / ratio
        if p > 0:
            pulley = own / (eta * ratio)
        elif p < 0:
            pulley = 0.0 if eta <= 0.5 else (2 * eta - 1) / eta * own / ratio
        t = pulley / arr["driven_radius"][i]
        T[i, i] = t
        for b in range(i, -1, -1):
            if Sdot[i, b] != 0:
                t = _upstream(t, Sdot[i, b], arr["tau0"][i, b], arr["beta"][i, b], arr["nu"][i, b])
            if b > 0:
                T[i, b - 1] = t
        Cm[i] = r_m[i] * t
    return Cm
