"""Controller design for the tendon drives: proportional and lead loops (S1 §3.4), plant fit, loop shaping
C = L/P̂ with robust performance (S1 §4.4), discretisation for the C++ bench loop."""
