"""tendyn: model, simulate, identify and compensate tendon (cable) transmissions.

The real-time parts live in a C++17 header-only core (``include/tendyn``) exposed as
:mod:`tendyn._core`; everything else is Python on top of it.
"""

__version__ = "0.1.0"
