"""Experiments on digital twins: the chain simulator (:mod:`.experiments`, :mod:`.model`) and the S1 tendon
bench (:mod:`.tendon_bench`). Every experiment takes a Device or its :func:`tendyn.device.compile_device`
form; frequency responses are :class:`FrequencyResponse` objects."""

from tendyn.results import FrequencyResponse

__all__ = ["FrequencyResponse"]
