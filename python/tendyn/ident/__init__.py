"""Identification estimators (scikit-learn style: hyper-parameters in ``__init__``, ``fit`` returns self,
learned values end in ``_``). They read logs (:mod:`tendyn.io`) and device descriptions, never a twin's
truth.

* :mod:`tendyn.ident.plateaus` — constant-speed segments from a quantised encoder.
* :mod:`tendyn.ident.friction` — :class:`TransmissionFriction`, S0's constant-velocity friction law (C7).
* :mod:`tendyn.ident.friction_file` — the FRICTION.json format (``tendyn.friction/1``).
* :mod:`tendyn.ident.decomposition` — per-branch losses from the global values (S0 eqs. 18–21, C9).
* :mod:`tendyn.ident.model` — :class:`IdentModel`: standard parameters in Khalil's order, the regressor of
  all samples in the C++ core, base parameters (issue 9).
* :mod:`tendyn.ident.treatment` — Gautier's data treatment: zero-phase Butterworth, central differences,
  parallel filter and decimation, sample alignment.
* :mod:`tendyn.ident.estimate` — :class:`IDIM`: OLS / WLS / essential / physically consistent
  (:mod:`tendyn.ident.consistent`), cross-validation; :mod:`tendyn.ident.stream` — logs too large for memory.
* :mod:`tendyn.ident.identified` — :class:`IdentifiedModel`: PARAMS.json loaded back, ``predict(log)`` (torques
  at the log's time stamps), ``score(log)``.
"""

from tendyn.ident.decomposition import LossDecomposition, decompose, default_shares, kinematic_coefficients
from tendyn.ident.estimate import IDIM, IdentificationResult, least_squares
from tendyn.ident.friction import (FrictionFit, IdentificationError, TransmissionFriction,
                                   residual_error_bound)
from tendyn.ident.friction_file import FrictionFileError, read_friction, write_friction
from tendyn.ident.model import IdentModel, khalil_from_pinocchio, pinocchio_from_khalil
from tendyn.ident.plateaus import Plateau, find_plateaus, windowed_slope
from tendyn.ident.treatment import (AlignmentError, Treatment, butter_zero_phase, default_treatment,
                                    parallel_filter_taps)

__all__ = ["IDIM", "AlignmentError", "FrictionFileError", "FrictionFit", "IdentModel", "IdentificationError",
           "IdentificationResult", "LossDecomposition", "Plateau", "Treatment", "TransmissionFriction",
           "butter_zero_phase", "decompose", "default_shares", "default_treatment", "find_plateaus",
           "khalil_from_pinocchio", "kinematic_coefficients", "least_squares", "parallel_filter_taps",
           "pinocchio_from_khalil", "read_friction", "residual_error_bound", "windowed_slope", "write_friction"]
