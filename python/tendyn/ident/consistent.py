"""Physically consistent identification: the standard parameters of every link constrained by its
pseudo-inertia matrix J = [[½ tr(I) 1 − I, h], [hᵀ, m]] ⪰ 0 (Wensing, Kim, Slotine 2017: equivalent to a
positive mass distribution), rotor inertias and friction coefficients ≥ 0; min ‖W x − Y‖² solved with cvxpy
and the Clarabel interior-point solver. The problem is posed on the R factor of W (W = QR), so its size does
not grow with the number of samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BoundsInfeasible", "check_bounds", "consistent_fit"]


COM_BOUND = ("CX", "CY", "CZ")
"""Bound names ``CX<j>``, ``CY<j>``, ``CZ<j>``: link j's centre of mass [m] in its frame (first moment / mass)."""


NON_NEGATIVE = ("M", "IA", "FV", "FS")
"""Stems the consistent fit keeps ≥ 0 (the mass through J ⪰ 0; rotor inertias and friction coefficients, motor
side too, by constraint): a box whose upper bound is below 0 admits nothing."""


class BoundsInfeasible(ValueError):
    """Boxes that, with the pseudo-inertia LMIs and the non-negative friction and rotor inertias, admit no
    parameters."""


def _stem(name: str) -> str:
    stem = name.rstrip("0123456789")
    return stem[:-1] if stem.endswith("m") and stem[:-1] in ("IA", "FV", "FS") else stem


def check_bounds(model, bounds, units=None) -> dict:
    """``bounds`` {name: (lower, upper)} validated against the device's standard parameters: a name is a standard
    parameter (``M2``, ``FS1``, ``OFFSET3``, ``IAm6``, a term's ``wrist_spring_k``; its unit) or ``CX<j>``/``CY<j>``/
    ``CZ<j>``, link j's centre of mass [m] (linear: lower·M_j ≤ MX_j ≤ upper·M_j, with M_j ≥ 0); None: no bound on
    that side. ``units`` {name: unit} stated by a file: each must be the parameter's unit (``model.unit``, "m" for a
    centre of mass; "(motor side)" need not be written). Raises ValueError naming an unknown name, lower > upper,
    a unit that differs, or an upper bound < 0 on a parameter the fit keeps ≥ 0 (:data:`NON_NEGATIVE`)."""
    names = set(model.standard_names)
    out = {}
    for name, pair in dict(bounds or {}).items():
        lo, hi = pair
        com = name not in names and name[:2] in COM_BOUND and f"M{name[2:]}" in names
        if not (name in names or com):
            raise ValueError(f"bounds: {name!r} is not a standard parameter of {model.device.name} nor CX/CY/CZ<link> "
                             f"(standard: {', '.join(model.standard_names)})")
        lo = None if lo is None else float(lo)
        hi = None if hi is None else float(hi)
        if lo is not None and hi is not None and lo > hi:
            raise ValueError(f"bounds: {name} lower {lo} > upper {hi}")
        if hi is not None and hi < 0 and not com and _stem(name) in NON_NEGATIVE:
            raise ValueError(f"bounds: {name} upper {hi!r} < 0: the consistent fit keeps {name} ≥ 0, the box admits "
                             "nothing")
        if units and name in units:
            unit = "m" if com else model.unit(name).replace(" (motor side)", "")
            if units[name].replace(" (motor side)", "").strip() != unit:
                raise ValueError(f"bounds: {name} is in {unit or 'its own unit'}, not {units[name]!r}")
        out[name] = (lo, hi)
    return out


def consistent_fit(model, W, Y, eps: float = 0.0, bounds=None) -> np.ndarray:
    """Standard parameters (``model.standard_names`` order) minimising ‖W x − Y‖ under the LMIs.

    ``W`` is the (weighted) standard regressor; its null space is fixed by a tiny pull (1e-8 relative)
    towards the device's prior, which changes no base parameter beyond the solver tolerance. ``bounds``:
    box constraints on standard parameters and centres of mass (:func:`check_bounds`), as a peer's
    hand-chosen boxes (WPI's dVRK SDP: masses, centres of mass, friction, spring stiffness).
    """
    import cvxpy as cp

    names = model.standard_names
    idx = {n: k for k, n in enumerate(names)}
    bounds = check_bounds(model, bounds)
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
    for name, (lo, hi) in bounds.items():
        if name[:2] in COM_BOUND and name not in idx:
            first, mass = x[idx[f"M{name[1]}{name[2:]}"]], x[idx[f"M{name[2:]}"]]
            cons += ([first >= lo * mass] if lo is not None else []) + ([first <= hi * mass] if hi is not None else [])
        else:
            cons += ([x[idx[name]] >= lo] if lo is not None else []) + ([x[idx[name]] <= hi] if hi is not None else [])
    scale = float(np.linalg.norm(z)) or 1.0
    prior = model.prior()
    reg = 1e-8 * scale * cp.sum_squares(x - prior)
    prob = cp.Problem(cp.Minimize(cp.sum_squares(R @ x - z) / scale + reg), cons)
    prob.solve(solver=cp.CLARABEL)
    if bounds and prob.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise BoundsInfeasible(f"the boxes ({len(bounds)}) and physical consistency admit no parameters (solver: "
                               f"{prob.status}): widen the boxes")
    if x.value is None:
        raise RuntimeError(f"the consistent identification failed: solver status {prob.status}")
    return np.asarray(x.value, float)


def completed_standard(model, names, values) -> np.ndarray:
    """Standard parameters (``model.standard_names`` order) that reproduce identified base values: each base
    parameter's own standard column solved for, every standard parameter the data cannot separate at the device
    file's value (:meth:`IdentModel.prior`). A base parameter not in ``names`` (omitted) is taken as 0."""
    base = model.base
    prior = model.prior()
    x = prior.copy()
    given = dict(zip(names, values))
    for i, name in enumerate(base.names):
        k = base.columns[i]
        x[k] = float(given.get(name, 0.0)) - (base.combination[i] @ prior - prior[k])
    return x


def _pseudo_inertia(v, idx, num) -> np.ndarray:
    """J (4, 4) of link ``num`` from standard parameters v (``idx``: name → index)."""
    g = lambda p: float(v[idx[f"{p}{num}"]])
    inertia = np.array([[g("XX"), g("XY"), g("XZ")], [g("XY"), g("YY"), g("YZ")], [g("XZ"), g("YZ"), g("ZZ")]])
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    J[:3, 3] = J[3, :3] = [g("MX"), g("MY"), g("MZ")]
    J[3, 3] = g("M")
    return J


def best_min_eigenvalue(model, names, values, links) -> list[float]:
    """Per listed link a t_j ≤ 0 [kg·m²], Σ t_j as large as possible, such that some standard parameters
    reproduce the identified base values exactly (omitted ones 0) with each link's pseudo-inertia J_j ⪰ t_j·1: all
    0 means a mass distribution has these base parameters; t_j < 0 names the links no completion of what the
    data cannot separate makes physical.

    A small SDP posed directly for the Clarabel interior-point solver (its Python module imports in a tenth of
    the time cvxpy takes): variables z = (x, t), cones Ax + s = b: zero (combination x = x_b), non-negative
    (−t ≥ 0), and per link the 4 × 4 PSD triangle of J_j(x) − t_j 1 (upper triangle, column-major, off-diagonal
    entries × √2)."""
    import clarabel
    import scipy.sparse as sp

    base = model.base
    idx = {n: k for k, n in enumerate(model.standard_names)}
    given = dict(zip(names, values))
    xb = np.array([float(given.get(n, 0.0)) for n in base.names])
    n, L = len(model.standard_names), len(links)
    rows, cols, vals, b = [], [], [], []

    def row(entries, rhs):
        r = len(b)
        for k, v in entries:
            rows.append(r); cols.append(k); vals.append(v)
        b.append(rhs)

    comb = base.combination
    for i in range(comb.shape[0]):                          # zero cone: combination x = x_b
        row([(k, comb[i, k]) for k in np.flatnonzero(comb[i])], xb[i])
    for j in range(L):                                      # −t_j ≥ 0
        row([(n + j, 1.0)], 0.0)
    r2 = np.sqrt(2.0)
    for j, num in enumerate(links):
        g = lambda p: idx[f"{p}{num}"]
        XX, YY, ZZ = g("XX"), g("YY"), g("ZZ")
        J = {(0, 0): [(XX, -0.5), (YY, 0.5), (ZZ, 0.5)], (1, 1): [(XX, 0.5), (YY, -0.5), (ZZ, 0.5)],
             (2, 2): [(XX, 0.5), (YY, 0.5), (ZZ, -0.5)], (0, 1): [(g("XY"), -1.0)], (0, 2): [(g("XZ"), -1.0)],
             (1, 2): [(g("YZ"), -1.0)], (0, 3): [(g("MX"), 1.0)], (1, 3): [(g("MY"), 1.0)],
             (2, 3): [(g("MZ"), 1.0)], (3, 3): [(g("M"), 1.0)]}
        for c in range(4):
            for r in range(c + 1):
                w = 1.0 if r == c else r2
                entries = [(k, -w * v) for k, v in J[(r, c)]] + ([(n + j, 1.0)] if r == c else [])
                row(entries, 0.0)                          # s = b − A z = svec(J − t 1)
    A = sp.csc_matrix((vals, (rows, cols)), shape=(len(b), n + L))
    P = sp.csc_matrix((n + L, n + L))
    q = np.concatenate([np.zeros(n), -np.ones(L)])
    cones = [clarabel.ZeroConeT(comb.shape[0]), clarabel.NonnegativeConeT(L)] + \
        [clarabel.PSDTriangleConeT(4) for _ in links]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    sol = clarabel.DefaultSolver(P, q, A, np.array(b), cones, settings).solve()
    t = np.asarray(sol.x, float)[n:] if str(sol.status).endswith("Solved") else None
    if t is None:
        return [-np.inf] * L
    out = []
    for k, num in enumerate(links):      # the solver's tolerance: 1e-4 of the link's own scale (its file J)
        lam = float(np.max(np.abs(_pseudo_inertia(model.prior(), idx, num))))
        out.append(0.0 if t[k] > -1e-4 * lam else float(t[k]))
    return out


def pseudo_inertia_check(model, x) -> list[dict]:
    """Per link of the tree: the smallest eigenvalue [kg·m²] of its pseudo-inertia J = [[½ tr(I) 1 − I, h],
    [hᵀ, m]] (Wensing, Kim, Slotine 2017) at the standard parameters x, and whether J is positive definite
    (``ok``); links whose device-file J is not positive definite (massless frames) are left out."""
    idx = {n: k for k, n in enumerate(model.standard_names)}
    prior = model.prior()
    out = []
    J_of = lambda v, num: _pseudo_inertia(v, idx, num)

    for num in model.tree_numbers:
        J0 = J_of(prior, num)
        ev0 = np.linalg.eigvalsh(J0)
        if ev0[0] <= 1e-12 * max(1.0, ev0[-1]):
            continue
        ev = float(np.linalg.eigvalsh(J_of(x, num))[0])
        out.append({"link": int(num), "min_eigenvalue": ev, "ok": bool(ev > 0.0)})
    return out
