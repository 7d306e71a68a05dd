"""Fitting a block model: residuals and Jacobians, Levenberg–Marquardt, a stable A, and the starting
points (ARX, the nonlinearity's linear columns, the Lur'e level, the sign of an ``abs`` model)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .block_nonlinearities import LURE_STRUCTURES, LURE_SUBSTEPS, NONLINEARITIES
from .block_records import Record
from .block_simulation import _lfilter, _lure_family_simulate, _shifted


LURE_TOL = 1e-7
"""Relative decrease of the cost below which the Lur'e fit stops (its cost is rough at the scale of one
sample's stick/slip change: finer tolerances buy evaluations, not accuracy)."""


def _lure_residual_and_jac(n, theta, records, want_jac, skip, structure="lure", substeps=1):
    """Residual of the Lur'e model and its Jacobian by forward differences (b_0 ≡ 0: its column is zero, so
    the step leaves it at 0). The recursion's stick/slip choice is redone at each perturbed θ; ŷ jumps (by
    about the velocity of one threshold |b_1| F a sample) where a sample changes between stick and slip, a
    set of measure zero that a step of 1e-7 relative seldom meets."""
    def res(th):
        r = np.concatenate([(_lure_family_simulate(structure, th[1:n + 1], th[n + 1:2 * n + 1], th[2 * n + 1:],
                                                   rec.u, substeps) - rec.y)[skip:] for rec in records])
        bad = ~np.isfinite(r)
        return np.where(bad, 1e6, np.clip(r, -1e6, 1e6)) if bad.any() else r

    r = res(theta)
    if not want_jac:
        return r
    J = np.zeros((r.size, theta.size))
    umax = max(float(np.max(np.abs(rec.u))) for rec in records) or 1.0
    scale = np.concatenate([[0.0], np.full(n, np.abs(theta[1:n + 1]).max() or 1.0), np.ones(n), [umax],
                            np.ones(theta.size - 2 * n - 2)])
    for j in range(1, theta.size):
        h = 1e-7 * (abs(theta[j]) + 1e-2 * scale[j])
        th = theta.copy()
        th[j] += h
        J[:, j] = (res(th) - r) / (th[j] - theta[j])
    return r, J


def _residual_and_jac(structure, nl, n, theta, records, want_jac, skip):
    if structure in LURE_STRUCTURES:
        return _lure_residual_and_jac(n, theta, records, want_jac, skip, structure,
                                      LURE_SUBSTEPS if nl.name == "coulomb-tension" else 1)
    b, a, p = theta[:n + 1], theta[n + 1:2 * n + 1], theta[2 * n + 1:]
    A = np.concatenate([[1.0], a])
    res, jacs = [], []
    for r in records:
        v = r.u if structure == "wiener" else nl.f(r.u, p)
        x = _lfilter(b, A, v)
        yhat = nl.f(x, p) if structure == "wiener" else x
        res.append((yhat - r.y)[skip:])
        if not want_jac:
            continue
        wv = _lfilter([1.0], A, v)
        wx = _lfilter([1.0], A, x)
        J = np.empty((r.u.size, theta.size))
        for k in range(n + 1):
            J[:, k] = _shifted(wv, k)
        for k in range(1, n + 1):
            J[:, n + k] = -_shifted(wx, k)
        if structure == "wiener":
            J[:, :2 * n + 1] *= nl.dfdx(x, p)[:, None]
            J[:, 2 * n + 1:] = nl.dfdp(x, p)
        else:
            dp = nl.dfdp(r.u, p)
            for j in range(dp.shape[1]):
                J[:, 2 * n + 1 + j] = _lfilter(b, A, dp[:, j])
        jacs.append(J[skip:])
    r = np.concatenate(res)
    bad = ~np.isfinite(r)
    if bad.any():                                    # an unstable trial point: a large, finite cost
        r = np.where(bad, 1e6, np.clip(r, -1e6, 1e6))
    if not want_jac:
        return r
    J = np.concatenate(jacs)
    return r, np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0)


def _stabilise(a):
    """Reflect the poles of 1 + a_1 z⁻¹ + … outside the unit circle inside it (same magnitude response shape)."""
    roots = np.roots(np.concatenate([[1.0], a]))
    big = np.abs(roots) >= 1.0
    if not big.any():
        return a
    roots[big] = 0.98 / np.conj(roots[big])
    return np.real(np.poly(roots))[1:]


def _arx(records, n, nl_in=None):
    """ARX least squares y_t + Σ a_k y_{t−k} = Σ b_k v_{t−k} (v = u, or f(u) for Hammerstein); stable a."""
    rows, rhs = [], []
    for r in records:
        v = r.u if nl_in is None else nl_in(r.u)
        y = r.y
        cols = [_shifted(v, k) for k in range(n + 1)] + [-_shifted(y, k) for k in range(1, n + 1)]
        rows.append(np.column_stack(cols)[n:])
        rhs.append(y[n:])
    theta, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    return theta[:n + 1], _stabilise(theta[n + 1:])


@dataclass
class _Solution:
    x: np.ndarray
    cost: float
    nfev: int


def _solve(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol=1e-10):
    """Levenberg–Marquardt on the output error with the exact Jacobian: the normal equations JᵀJ are
    (2n + 1 + p)² small, so a step costs the simulation and two filters per record, never a factorisation of
    J (a thin SVD of a 10 000 × 8 Jacobian costs more than the whole simulation); thresholds are kept above
    their lower bounds by projection."""
    with np.errstate(over="ignore", invalid="ignore"):     # unstable trial points are rejected by their cost
        return _lm(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol)


def _lm(structure, nl, n, theta0, records, skip, max_nfev, lower_nl, tol):
    lb = np.concatenate([np.full(2 * n + 1, -np.inf), lower_nl])
    theta = np.maximum(np.asarray(theta0, float), lb)
    r, J = _residual_and_jac(structure, nl, n, theta, records, True, skip)
    cost, lam, nfev = float(r @ r), 1e-3, 1
    while nfev < max_nfev:
        g, H = J.T @ r, J.T @ J
        d = np.diag(H).copy()
        d[d <= 0] = 1.0
        while nfev < max_nfev:
            try:
                step = np.linalg.solve(H + lam * np.diag(d), -g)
            except np.linalg.LinAlgError:
                step = np.zeros_like(theta)
            trial = np.maximum(theta + step, lb)
            if structure in LURE_STRUCTURES:     # a Jacobian costs 2n simulations: only at accepted points
                r2 = _residual_and_jac(structure, nl, n, trial, records, False, skip)
            else:                       # the Jacobian shares the simulation: with every trial
                r2, J2 = _residual_and_jac(structure, nl, n, trial, records, True, skip)
            nfev += 1
            c2 = float(r2 @ r2)
            if c2 < cost:
                if structure in LURE_STRUCTURES:
                    r2, J2 = _residual_and_jac(structure, nl, n, trial, records, True, skip)
                break
            lam *= 4.0
            if lam > 1e12:
                return _Solution(theta, cost, nfev)
        else:
            break
        small = (cost - c2 <= tol * cost) or np.linalg.norm(trial - theta) <= tol * (np.linalg.norm(theta) + tol)
        theta, r, J, cost = trial, r2, J2, c2
        lam = max(lam / 3.0, 1e-12)
        if small:
            break
    return _Solution(theta, cost, nfev)


def _initial_nonlinear(structure, nl, n, b, a, records, degree_cols):
    """Rescale G and choose p by linear least squares on the basis of the nonlinearity
    (:mod:`tendyn.ident.blockmodel`'s docstring)."""
    A = np.concatenate([[1.0], a])
    z = [_lfilter(b, A, r.u) if structure == "wiener" else r.u for r in records]
    y = np.concatenate([r.y for r in records])

    def design(phis):       # Wiener: Φ(z); Hammerstein: G Φ(u)
        if structure == "wiener":
            return np.column_stack([np.concatenate([phi(zz) for zz in z]) for phi in phis])
        return np.column_stack([np.concatenate([_lfilter(b, A, phi(zz)) for zz in z]) for phi in phis])

    if nl.threshold:
        mag = np.abs(np.concatenate(z))
        best = None
        for q in (0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8):
            t = max(float(np.quantile(mag, q)), 1e-12 * (mag.max() or 1.0))
            X = design([lambda s, t=t: nl.f(s, [t])])
            g = float(X[:, 0] @ y / (X[:, 0] @ X[:, 0])) if X[:, 0] @ X[:, 0] > 0 else 0.0
            cost = float(np.sum((y - g * X[:, 0]) ** 2))
            if g > 0 and (best is None or cost < best[0]):
                best = (cost, g, t)
        if best is None:
            return b, np.array([1e-6 * (mag.max() or 1.0)])
        _, g, t = best
        return g * b, np.array([g * t if structure == "wiener" else t])
    if nl.name == "abs":
        X = design([np.abs])
        g = float(X[:, 0] @ y / (X[:, 0] @ X[:, 0]))
        return g * b, np.zeros(0)
    if nl.name == "coulomb":
        w, *_ = np.linalg.lstsq(design([lambda s: s, np.sign]), y, rcond=None)
        g = w[0] if abs(w[0]) > 1e-12 else 1.0
        return g * b, np.array([w[1] if structure == "wiener" else w[1] / g])
    ks = np.arange(1, degree_cols + 2)
    w, *_ = np.linalg.lstsq(design([lambda s, k=k: s ** k for k in ks]), y, rcond=None)
    g = w[0] if abs(w[0]) > 1e-12 else 1.0
    c = [w[k - 1] / (g ** k if structure == "wiener" else g) for k in ks[1:]]
    return g * b, np.array(c)


def _initial_lure(n, records):
    """Initial Lur'e model by equation error with the friction's sign read from the measured output: where
    the output moved over the n samples a step depends on (|Δy| above round-off: slip), φ_j = F sgn(Δy_{j+1})
    and y_{t+1} + Σ a_k y_{t+1−k} = Σ b_k u_{t+1−k} − Σ c_k sgn(Δy_{t+2−k}) is linear in (a, b, c = b F);
    F = c·b / b·b (≥ 0), a stabilised. Stuck samples are left out (their φ is unknown)."""
    rows, rhs = [], []
    for r in records:
        y, u = r.y, r.u
        dy = np.diff(y, append=y[-1])                  # dy[j] = y_{j+1} − y_j
        s = np.sign(dy)
        moving = np.abs(dy) > 1e-9 * (np.ptp(y) or 1.0)
        ok = np.ones(y.size, bool)                    # row t predicts y_{t+1} from samples t+1−k, k = 1…n
        for k in range(n):
            ok &= _shifted(moving.astype(float), k) > 0
        cols = ([-_shifted(y, k) for k in range(n)] + [_shifted(u, k) for k in range(n)]
                + [-_shifted(s, k) for k in range(n)])
        X = np.column_stack(cols)[n - 1:-1]
        keep = ok[n - 1:-1]
        rows.append(X[keep])
        rhs.append(y[n:][keep])
    X, Y = np.concatenate(rows), np.concatenate(rhs)
    if Y.size < 3 * n + 1:
        raise ValueError(f"too few moving samples ({Y.size}) for a Lur'e model of order {n}")
    th, *_ = np.linalg.lstsq(X, Y, rcond=None)
    a, b, c = th[:n], th[n:2 * n], th[2 * n:]
    F = max(float(c @ b / (b @ b)), 0.0) if b @ b > 0 else 0.0
    return np.concatenate([[0.0], b]), _stabilise(a), np.array([F])


def _kernel_signs(records, lags=24):
    """A sign sequence for x = G u from y = |x|: y² = (g * u)² is a quadratic form in the lagged inputs,
    y²_t ≈ Σ_ij Q_ij u_{t−i} u_{t−j} with Q = g gᵀ (g the first ``lags`` samples of G's impulse response);
    Q by least squares, g (up to its sign) its leading eigenvector, s = sgn(g * u)."""
    rows, rhs = [], []
    iu = np.triu_indices(lags)
    for r in records:
        U = np.column_stack([_shifted(r.u, k) for k in range(lags)])
        rows.append((U[:, iu[0]] * U[:, iu[1]])[lags:])
        rhs.append(r.y[lags:] ** 2)
    q, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    Q = np.zeros((lags, lags))
    Q[iu] = q
    Q = 0.5 * (Q + Q.T)
    w, V = np.linalg.eigh(Q)
    g = V[:, -1] * math.sqrt(max(w[-1], 0.0))
    return [np.sign(np.convolve(r.u, g)[:r.u.size]) + 0.0 for r in records]


def _abs_sign_recovery(records, n, skip, max_nfev, rounds=4):
    """Linear initial estimate of a Wiener model with f = |x| (its best linear approximation is zero: f is
    even). Two sign sequences are tried for x — sgn(u) and the output's own dips (:func:`_output_signs`) —
    each refined by alternating an ARX fit of s·y on u with s = sgn(G u), then by output error with |·|;
    the one of lower cost is kept (G and −G are the same model)."""
    nl = NONLINEARITIES["abs"]
    best = None
    for signs in ([np.sign(r.u) for r in records], _kernel_signs(records)):
        signs = [s + (s == 0) for s in signs]
        for _ in range(rounds):
            b, a = _arx([Record(r.u, s * r.y, r.rate_hz) for r, s in zip(records, signs)], n)
            signs = [np.sign(_lfilter(b, np.concatenate([[1.0], a]), r.u)) for r in records]
            signs = [s + (s == 0) for s in signs]
        sol = _solve("wiener", nl, n, np.concatenate([b, a]), records, skip, max_nfev, np.zeros(0))
        if best is None or sol.cost < best.cost:
            best = sol
    return best.x[:n + 1], _stabilise(best.x[n + 1:2 * n + 1])
