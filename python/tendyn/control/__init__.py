"""Real-time control on the C++ core: the compensator and the haptic renderer (S0 §IV-B, C10, C46)."""

from .compensator import Compensator, chain_model, end_effector_point, transmission_with_friction
from .render import Renderer

__all__ = ["Compensator", "Renderer", "chain_model", "end_effector_point", "transmission_with_friction"]
