"""Identification estimators (scikit-learn style: hyper-parameters in ``__init__``, ``fit`` returns self,
learned values end in ``_``). They read logs (:mod:`tendyn.io`) and device descriptions, never a twin's
truth.

* :mod:`tendyn.ident.plateaus` — constant-speed segments from a quantised encoder.
* :mod:`tendyn.ident.friction` — :class:`TransmissionFriction`, S0's constant-velocity friction law (C7).
* :mod:`tendyn.ident.friction_file` — the FRICTION.json format (``tendyn.friction/1``).
* :mod:`tendyn.ident.decomposition` — per-branch losses from the global values (S0 eqs. 18–21, C9).
"""

from tendyn.ident.decomposition import LossDecomposition, decompose, default_shares, kinematic_coefficients
from tendyn.ident.friction import (FrictionFit, IdentificationError, TransmissionFriction,
                                   residual_error_bound)
from tendyn.ident.friction_file import FrictionFileError, read_friction, write_friction
from tendyn.ident.plateaus import Plateau, find_plateaus, windowed_slope

__all__ = ["FrictionFileError", "FrictionFit", "IdentificationError", "LossDecomposition", "Plateau",
           "TransmissionFriction", "decompose", "default_shares", "find_plateaus", "kinematic_coefficients",
           "read_friction", "residual_error_bound", "windowed_slope", "write_friction"]
