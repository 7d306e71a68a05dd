"""Capstan stiffness (S2 §V, eq. 19): the one definition of the total stiffness of a capstan drive and of a
motor-side stiffness seen at the joint. The device (``Drive.total_stiffness_motor``, ``Drive.stiffness_joint``),
the operational maps (:mod:`tendyn.analysis.operational`) and the S2 pipeline (``capstan_bandwidth``) read it;
numpy only, so the device schema may use it."""

from __future__ import annotations

import numpy as np

__all__ = ["reflected_stiffness", "total_stiffness"]


def total_stiffness(stiffness_motor, servo_stiffness_motor=None):
    """K_tot = 1 / (1/K_T + 1/K_E) [N·m/rad], motor side (S2 eq. 19): the capstan cable K_T in series with the
    position servo K_E; K_E None (or inf) gives K_T, K_E = 0 gives 0. Scalars or arrays (per drive). The one
    definition the device (``Drive.total_stiffness_motor``), the operational maps and the S2 pipeline read."""
    kt = np.asarray(stiffness_motor, float)
    ke = np.inf if servo_stiffness_motor is None else np.asarray(servo_stiffness_motor, float)
    with np.errstate(divide="ignore"):
        k = 1.0 / (1.0 / kt + 1.0 / ke)
    return float(k) if np.ndim(k) == 0 else k


def reflected_stiffness(stiffness_motor, ratio):
    """A motor-side stiffness seen at the joint [N·m/rad] = N² K (ERRATA eq. 19: the motor turns N q). Scalars
    or arrays (per drive)."""
    k = np.asarray(ratio, float) ** 2 * np.asarray(stiffness_motor, float)
    return float(k) if np.ndim(k) == 0 else k
