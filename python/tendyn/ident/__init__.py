"""Identification of a device's dynamic parameters from logs (IDIM least squares, Gautier's data treatment).

``IdentModel`` (standard parameters in Khalil's order, regressor of all samples in the C++ core, base
parameters), ``treatment`` (zero-phase Butterworth, central differences, parallel filter and decimation),
``IDIM`` (OLS / WLS / essential / physically consistent, scikit-learn shape). Imports device/, io/ and the
core only, never sim/.
"""

from .estimate import IDIM, IdentificationResult, least_squares
from .model import IdentModel, khalil_from_pinocchio, pinocchio_from_khalil
from .treatment import AlignmentError, Treatment, butter_zero_phase, default_treatment, parallel_filter_taps

__all__ = ["IDIM", "AlignmentError", "IdentModel", "IdentificationResult", "Treatment", "butter_zero_phase",
           "default_treatment", "khalil_from_pinocchio", "least_squares", "parallel_filter_taps",
           "pinocchio_from_khalil"]
