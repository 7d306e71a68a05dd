"""Physically consistent identification: the standard parameters of every link constrained by its
pseudo-inertia matrix J = [[½ tr(I) 1 − I, h], [hᵀ, m]] ⪰ 0 (Wensing, Kim, Slotine 2017: equivalent to a
positive mass distribution), rotor inertias and friction coefficients ≥ 0; min ‖W x − Y‖² solved with cvxpy
and the Clarabel interior-point solver. The problem is posed on the R factor of W (W = QR), so its size does
not grow with the number of samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BoundsInfeasible", "check_bounds", "consistent_fit", "consistent_problem"]


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


FORMS = ("tendyn", "wpi")
"""Shapes of the consistent problem (:func:`consistent_problem`): ``tendyn`` (posed on the R factor of W, scaled,
a 1e-8 pull to the prior fixing the null space, Clarabel) and ``wpi``, WPI's dVRK SDP (identification/sdp_opt.py
under cvxpy 1.0: min ‖W x − Y‖² over every row as cvxpy 1.0 canonicalised it, t with ‖(1 − t, 2(W x − Y))‖ ≤ 1 + t,
each link's J ⪰ 1e-6·1, the boxes and nothing else), for solving it with WPI's own solver."""

WPI_EPS = 1e-6
"""WPI's margin on the pseudo-inertia LMIs [kg·m²] (sdp_opt.py: ``small_positive_num``)."""


def consistent_problem(model, W, Y, eps: float = 0.0, bounds=None, form: str = "tendyn", fixed=None):
    """The consistent least squares as a cvxpy problem: (problem, x, free) with x the variable of the standard
    parameters listed in ``free`` (``model.standard_names`` order, those of ``fixed`` {name: value} left out and
    held at their value). ``form``: :data:`FORMS`; ``eps`` the LMIs' margin (``wpi``: :data:`WPI_EPS` when 0)."""
    import cvxpy as cp

    if form not in FORMS:
        raise ValueError(f"form must be one of {', '.join(FORMS)} (got {form!r})")
    names = model.standard_names
    fixed = dict(fixed or {})
    unknown = sorted(set(fixed) - set(names))
    if unknown:
        raise ValueError(f"fixed: not standard parameters of {model.device.name}: {', '.join(unknown)}")
    free = [n for n in names if n not in fixed]
    idx = {n: k for k, n in enumerate(free)}
    bounds = check_bounds(model, bounds)
    x = cp.Variable(len(free))
    g0 = lambda name: x[idx[name]] if name in idx else float(fixed[name])
    if form == "wpi" and eps == 0.0:
        eps = WPI_EPS
    cons = []
    for num in model.tree_numbers:
        g = lambda p: g0(f"{p}{num}")
        I = cp.bmat([[g("XX"), g("XY"), g("XZ")], [g("XY"), g("YY"), g("YZ")], [g("XZ"), g("YZ"), g("ZZ")]])
        tr = g("XX") + g("YY") + g("ZZ")
        S = 0.5 * tr * np.eye(3) - I
        h = cp.vstack([g("MX"), g("MY"), g("MZ")])
        J = cp.bmat([[S, h], [h.T, cp.reshape(g("M"), (1, 1), order="C")]])
        cons.append((J + J.T) / 2 >> eps * np.eye(4))
    if form == "tendyn":
        for n, k in idx.items():
            if n.startswith(("IA", "FV", "FS")):
                cons.append(x[k] >= 0)
    for name, (lo, hi) in bounds.items():
        if name[:2] in COM_BOUND and name not in model.standard_names:
            first, mass = g0(f"M{name[1]}{name[2:]}"), g0(f"M{name[2:]}")
            cons += ([first >= lo * mass] if lo is not None else []) + ([first <= hi * mass] if hi is not None else [])
        else:
            v = g0(name)
            cons += ([v >= lo] if lo is not None else []) + ([v <= hi] if hi is not None else [])
    keep = [names.index(n) for n in free]
    held = np.array([float(fixed.get(n, 0.0)) for n in names])
    Wf, Yf = W[:, keep], Y - W @ held
    if form == "wpi":
        t = cp.Variable()
        cons.append(cp.SOC(1 + t, cp.hstack([cp.reshape(1 - t, (1,), order="C"), 2 * (Wf @ x - Yf)])))
        return cp.Problem(cp.Minimize(t), cons), x, free
    Q, R = np.linalg.qr(Wf)
    z = Q.T @ Yf
    scale = float(np.linalg.norm(z)) or 1.0
    prior = model.prior()[keep]
    reg = 1e-8 * scale * cp.sum_squares(x - prior)
    return cp.Problem(cp.Minimize(cp.sum_squares(R @ x - z) / scale + reg), cons), x, free


def consistent_fit(model, W, Y, eps: float = 0.0, bounds=None, form: str = "tendyn", fixed=None,
                   solve=None) -> np.ndarray:
    """Standard parameters (``model.standard_names`` order) minimising ‖W x − Y‖ under the LMIs.

    ``W`` is the (weighted) standard regressor; its null space is fixed by a tiny pull (1e-8 relative)
    towards the device's prior, which changes no base parameter beyond the solver tolerance. ``bounds``:
    box constraints on standard parameters and centres of mass (:func:`check_bounds`), as a peer's
    hand-chosen boxes (WPI's dVRK SDP: masses, centres of mass, friction, spring stiffness). ``form``, ``fixed``:
    :func:`consistent_problem`. ``solve``: None (Clarabel, to convergence) or a callable that solves the cvxpy
    problem it is given and leaves the variables' values set (a peer's own solver: benchmarks/realdata).
    """
    import cvxpy as cp

    prob, x, free = consistent_problem(model, W, Y, eps, bounds, form, fixed)
    if solve is None:
        prob.solve(solver=cp.CLARABEL)
    else:
        solve(prob)
    if bounds and prob.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise BoundsInfeasible(f"the boxes ({len(bounds)}) and physical consistency admit no parameters (solver: "
                               f"{prob.status}): widen the boxes")
    if x.value is None:
        raise RuntimeError(f"the consistent identification failed: solver status {prob.status}")
    out = np.array([float(dict(fixed or {}).get(n, 0.0)) for n in model.standard_names])
    out[[model.standard_names.index(n) for n in free]] = np.asarray(x.value, float)
    return out


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
