"""Physically consistent identification: the standard parameters of every link constrained by its
pseudo-inertia matrix J = [[½ tr(I) 1 − I, h], [hᵀ, m]] ⪰ 0 (Wensing, Kim, Slotine 2017: equivalent to a
positive mass distribution), rotor inertias and friction coefficients ≥ 0; min ‖W x − Y‖² solved with cvxpy
and the Clarabel interior-point solver. The problem is posed on the R factor of W (W = QR), so its size does
not grow with the number of samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["consistent_fit"]


def consistent_fit(model, W, Y, eps: float = 0.0) -> np.ndarray:
    """Standard parameters (``model.standard_names`` order) minimising ‖W x − Y‖ under the LMIs.

    ``W`` is the (weighted) standard regressor; its null space is fixed by a tiny pull (1e-8 relative)
    towards the device's prior, which changes no base parameter beyond the solver tolerance.
    """
    import cvxpy as cp

    names = model.standard_names
    idx = {n: k for k, n in enumerate(names)}
    Q, R = np.linalg.qr(W)
    z = Q.T @ Y
    x = cp.Variable(len(names))
    cons = []
    for num in model.tree_numbers:
        g = lambda p: x[idx[f"{p}{num}"]]
        I = cp.bmat([[g("XX"), g("XY"), g("XZ")], [g("XY"), g("YY"), g("YZ")], [g("XZ"), g("YZ"), g("ZZ")]])
        tr = g("XX") + g("YY") + g("ZZ")
        S = 0.5 * tr * np.eye(3) - I
        h = cp.vstack([g("MX"), g("MY"), g("MZ")])
        J = cp.bmat([[S, h], [h.T, cp.reshape(g("M"), (1, 1), order="C")]])
        cons.append((J + J.T) / 2 >> eps * np.eye(4))
    for n, k in idx.items():
        if n.startswith(("IA", "FV", "FS")):
            cons.append(x[k] >= 0)
    scale = float(np.linalg.norm(z)) or 1.0
    prior = model.prior()
    reg = 1e-8 * scale * cp.sum_squares(x - prior)
    prob = cp.Problem(cp.Minimize(cp.sum_squares(R @ x - z) / scale + reg), cons)
    prob.solve(solver=cp.CLARABEL)
    if x.value is None:
        raise RuntimeError(f"the consistent identification failed: solver status {prob.status}")
    return np.asarray(x.value, float)
