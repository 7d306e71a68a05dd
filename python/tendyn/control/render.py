"""Haptic rendering on the compensator (``include/tendyn/render.hpp``), S0 eq. (23) (C10).

F_d = (K_st + K_d s)(X_god − X̂) + F_fr + F_T with a god-object proxy against planes and a sphere, X̂ from
the motor encoders through the transmission and the direct kinematics, motor torques through the compensator.
"""

from __future__ import annotations

import numpy as np

from tendyn import _core
from tendyn.transmission import as_vector

from .compensator import Compensator

__all__ = ["Renderer"]


class Renderer:
    """A haptic scene rendered through a :class:`Compensator` (its model is shared, its data is own).

    Parameters
    ----------
    compensator : the compensator whose model the renderer uses
    stiffness : K_st [N/m]
    damping : K_d [N·s/m] (along the contact normal)
    surface_friction : μ [-], Coulomb friction on the proxy
    """

    def __init__(self, compensator: Compensator, stiffness: float = 2000.0, damping: float = 0.0,
                 surface_friction: float = 0.0):
        self.compensator = compensator.with_settings()
        self.model = _core.RenderModel()
        self.model.stiffness = float(stiffness)
        self.model.damping = float(damping)
        self.model.surface_friction = float(surface_friction)
        self.data = _core.RenderData()

    def add_plane(self, normal, offset: float) -> "Renderer":
        """Solid where normal·x < offset (normal unit, out of the solid; offset [m])."""
        n = as_vector(normal, "normal", 3)
        if not self.model.add_plane(n / np.linalg.norm(n), float(offset)):
            raise ValueError(f"cannot add the plane (at most {8} planes, finite offset)")
        return self

    def set_sphere(self, center, radius: float) -> "Renderer":
        """A solid sphere (center [m], radius [m] > 0)."""
        if not radius > 0:
            raise ValueError(f"radius must be > 0 (got {radius})")
        self.model.sphere = True
        self.model.sphere_center = as_vector(center, "center", 3)
        self.model.sphere_radius = float(radius)
        return self

    def set_texture(self, amplitude: float, period: float, direction=(1.0, 0.0, 0.0)) -> "Renderer":
        """Grating F_T = amplitude |F_n| sin(2π X_god·e / period) n (amplitude [-], period [m])."""
        e = as_vector(direction, "direction", 3)
        self.model.texture_amplitude = float(amplitude)
        self.model.texture_period = float(period)
        self.model.texture_direction = e / np.linalg.norm(e)
        return self

    def reset(self) -> None:
        self.data.reset()
        self.compensator.reset()

    def cycle(self, q_motor) -> np.ndarray:
        """One rendering cycle: encoder readings [rad] → motor torques [N·m] (F_d in ``data.force``)."""
        c = self.compensator
        _core.render_cycle(self.model, self.data, c.model, c.data, as_vector(q_motor, "q_motor", c.n))
        return np.array(c.data.torque_motor)
