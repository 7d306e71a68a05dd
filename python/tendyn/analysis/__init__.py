"""Frequency-domain and symbolic analysis (transfer functions, sensitivities, operational maps)."""
