"""Seeded random routings (1–7 joints), shared by the C1–C4 checks and the transmission tests."""

from __future__ import annotations

import numpy as np


def random_routing(rng, n=None, losses=False, reducers=True):
    """A random n-joint routing (1–7 joints), optionally with every kind of loss.

    Radii in m (motor pulleys 5–20 mm, idle pulleys ±5–30 mm or 0 for a cable on the axis, driven pulleys
    10–100 mm times a reducer ratio 2–20 half of the time); losses: τ0 [N], ν [N·s/m], β [-], bearings."""
    from tendyn.transmission import Transmission

    n = int(rng.integers(1, 8)) if n is None else n
    r_m = rng.uniform(0.005, 0.02, n)
    K = np.zeros((n, n))
    for i in range(n):
        for j in range(i):
            # an idle pulley of either sign, or the cable passing on the axis (radius 0)
            K[i, j] = 0.0 if rng.random() < 0.15 else rng.choice([-1, 1]) * rng.uniform(0.005, 0.03)
    ratio = np.where(rng.random(n) < 0.5, 1.0, rng.uniform(2, 20, n)) if reducers else np.ones(n)
    K[np.diag_indices(n)] = rng.uniform(0.01, 0.1, n) * ratio
    kw = {}
    if losses:
        low = np.tril(np.ones((n, n)))
        kw = dict(
            reducer_efficiency=np.where(ratio > 1, rng.uniform(0.55, 0.99, n), 1.0),
            pretension=rng.uniform(0, 80, n),
            tau0=low * rng.uniform(0, 2, (n, n)),
            nu=low * rng.uniform(0, 20, (n, n)),
            beta=low * rng.uniform(0, 0.05, (n, n)),
            bearing_count=low * rng.integers(0, 3, (n, n)),
            bearing_radius=np.full((n, n), 0.01),
            bearing_wrap=rng.uniform(0.5, np.pi, (n, n)),
            bearing_static_coefficient=rng.uniform(0, 2e-4, (n, n)),
            bearing_dynamic_coefficient=rng.uniform(0, 1.5e-4, (n, n)),
            bearing_h0=rng.uniform(0, 1e-3, (n, n)),
            bearing_h1=rng.uniform(0, 2e-4, (n, n)),
            bearing_n0=rng.uniform(0, 10, (n, n)),
        )
    return Transmission.from_arrays(r_m, K, ratio, **kw)
