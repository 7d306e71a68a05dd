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

# Names resolved on first use (PEP 562): `import tendyn.ident.blockmodel` or a command's registration does not pay
# for scipy.signal, Pinocchio and the estimators (issue 20 item 6: a quick CLI).
_LAZY = {
    "LossDecomposition": "decomposition", "decompose": "decomposition", "default_shares": "decomposition",
    "kinematic_coefficients": "decomposition",
    "IDIM": "estimate", "IdentificationResult": "estimate", "least_squares": "estimate",
    "FrictionFit": "friction", "IdentificationError": "friction", "TransmissionFriction": "friction",
    "residual_error_bound": "friction",
    "FrictionFileError": "friction_file", "read_friction": "friction_file", "write_friction": "friction_file",
    "IdentModel": "model", "khalil_from_pinocchio": "model", "pinocchio_from_khalil": "model",
    "Plateau": "plateaus", "find_plateaus": "plateaus", "windowed_slope": "plateaus",
    "AlignmentError": "treatment", "Treatment": "treatment", "butter_zero_phase": "treatment",
    "default_treatment": "treatment", "parallel_filter_taps": "treatment",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f"tendyn.ident.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'tendyn.ident' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = ["IDIM", "AlignmentError", "FrictionFileError", "FrictionFit", "IdentModel", "IdentificationError",
           "IdentificationResult", "LossDecomposition", "Plateau", "Treatment", "TransmissionFriction",
           "butter_zero_phase", "decompose", "default_shares", "default_treatment", "find_plateaus",
           "khalil_from_pinocchio", "kinematic_coefficients", "least_squares", "parallel_filter_taps",
           "pinocchio_from_khalil", "read_friction", "residual_error_bound", "windowed_slope", "write_friction"]
