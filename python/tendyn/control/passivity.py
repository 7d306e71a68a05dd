"""Settings of the passivity observer and controller at the compensator's motor ports (``passivity.hpp``).

The observer counts the energy the compensator's friction part injects at each motor against a certified lower
bound of that motor's dissipation, ``D_i(Δq) = c_i |Δq| + b_i Δq² / T``; the controller damps whatever exceeds
it (Hannaford & Ryu's passivity observer / controller). The bound must not come from the compensator's own
friction model (over-compensation is what it guards against): :func:`dissipation_bound` derives it from a
reference friction — the identified one (FRICTION.json) or the device's own losses — with a margin.

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> p = passivity_model(load_device(bundled("lexos")))
>>> p.enabled, len(p.dissipation_coulomb)
(True, 4)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tendyn import _core
from tendyn.control.transmission_losses import transmission_with_friction
from tendyn.device import CompiledDevice, Device, compile_device

__all__ = ["dissipation_bound", "passivity_model", "DEFAULT_MARGIN", "DEFAULT_RESERVE", "BOUND_SPEEDS"]

DEFAULT_MARGIN = 0.8
"""Fraction of the reference friction certified as dissipation [-] (20 % for identification error and drift)."""
DEFAULT_RESERVE = 0.002
"""Most dissipated energy the observer banks per motor [J] (it lets the compensator cover a short burst)."""
BOUND_SPEEDS = np.array([0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0])
"""Motor speeds [rad/s] at which the no-load friction is evaluated for the fit c + b v."""


def dissipation_bound(device: Device | CompiledDevice, friction=None, margin: float = DEFAULT_MARGIN
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Certified lower bound of each motor's friction, (c [N·m], b [N·m·s/rad]) per motor, motor side.

    For each motor i alone at speed v (the others held), the no-load friction torque it must supply is
    the motor torque of the statics with losses at zero joint torque (``motor_torque_feedforward``, S0 eqs. 4,
    6, 9–12, corrected: ERRATA) at the joint velocity ``K⁻¹ R_m v e_i``; a least-squares line c + b v through
    the speeds of :data:`BOUND_SPEEDS` (both clipped at 0) times ``margin``. Load-dependent losses (β, η_d)
    only add dissipation, so the no-load value bounds them from below.

    Parameters
    ----------
    friction : None, mapping or FRICTION.json path
        the reference friction (:func:`tendyn.control.transmission_with_friction`); None: the device's own
    margin : (0, 1] fraction certified
    """
    if not 0.0 < margin <= 1.0:
        raise ValueError(f"margin must be in (0, 1] (got {margin})")
    tr = transmission_with_friction(device, friction)
    n = tr.n
    A = np.column_stack([np.ones_like(BOUND_SPEEDS), BOUND_SPEEDS])
    coulomb, viscous = np.zeros(n), np.zeros(n)
    for i in range(n):
        torque = np.empty(len(BOUND_SPEEDS))
        for k, v in enumerate(BOUND_SPEEDS):
            qd = tr.motor_alone_joint_speeds(i, v)
            torque[k] = tr.feedforward(np.zeros(n), qd).torque_motor[i]
        c, b = np.linalg.lstsq(A, torque, rcond=None)[0]
        coulomb[i], viscous[i] = max(c, 0.0) * margin, max(b, 0.0) * margin
    return coulomb, viscous


def passivity_model(device: Device | CompiledDevice, friction=None, *, margin: float = DEFAULT_MARGIN,
                    reserve: float = DEFAULT_RESERVE, damping_max: float | None = None,
                    rate_hz: float = 1000.0) -> Any:
    """The core :class:`tendyn._core.PassivityModel` of a cable-driven device, enabled.

    Parameters
    ----------
    friction, margin : the reference friction and the fraction certified (:func:`dissipation_bound`)
    reserve : most dissipated energy banked per motor [J]
    damping_max : bound α_max of the controller's damping [N·m·s/rad]; default the smallest rotor inertia ×
        ``rate_hz`` (α_max T / J_rotor = 1: a one-period damper cannot reverse a free rotor)
    rate_hz : control rate [Hz]
    """
    from tendyn.ident.calibrated import unwrap

    device, friction = unwrap(device, friction)     # a calibrated device: its one loss model
    compiled = compile_device(device)
    coulomb, viscous = dissipation_bound(compiled, friction, margin)
    if damping_max is None:
        inertia = min(t.motor.rotor_inertia for t in (compiled.device.transmissions or compiled.device.drives))
        damping_max = inertia * rate_hz
    p = _core.PassivityModel()
    p.enabled = True
    p.dissipation_coulomb = coulomb
    p.dissipation_viscous = viscous
    p.reserve = float(reserve)
    p.damping_max = float(damping_max)
    problem = p.first_issue(len(coulomb))
    if problem:
        raise ValueError(f"{compiled.name}: {problem}")
    return p
