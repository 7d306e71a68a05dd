"""Control on the tendon devices.

* Real-time control on the C++ core: the compensator and the haptic renderer (S0 §IV-B, C10, C46), the passivity
  observer and controller at the compensator's motor ports (:mod:`tendyn.control.passivity`).
* Controller design for the tendon drives (:mod:`tendyn.control.loop_shaping`): proportional and lead loops
  (S1 §3.4), plant fit, loop shaping C = L/P̂ with robust performance (S1 §4.4), discretisation for the C++
  bench loop.
"""

from .compensator import Compensator, chain_model, end_effector_point, transmission_with_friction
from .passivity import dissipation_bound, passivity_model
from .render import Renderer

__all__ = ["Compensator", "Renderer", "chain_model", "dissipation_bound", "end_effector_point", "passivity_model",
           "transmission_with_friction"]
