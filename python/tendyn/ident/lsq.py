"""The one least squares of identification and its statistics (S2 eqs. 4–7; ERRATA eq. 5: the squared norm).

X̂ = argmin ‖√w (Y − W X)‖ (w = 1: OLS), σ̂² = ‖√w (Y − W X̂)‖² / (r − b), C = σ̂² (Wᵀ w W)⁻¹, σ = √diag C and
%σ = 100 σ / |X̂|; the instrumental-variable variant of IDIM-IV (:func:`instrumental_variables`). Every
estimator uses these: the IDIM in memory (W given), the streaming IDIM (only the
normal equations WᵀW, WᵀY, YᵀY and r are held: :func:`least_squares` takes them as ``normal=``), the S0
transmission friction (weighted bins) and the capstan stiffness of S2 §V-B.

Compact factors (:func:`row_factor`): the R of a QR of [W | y] stands for the rows W, y in every least squares,
‖[W | y] v‖ = ‖R v‖ for every v, so x̂, ‖y − W x̂‖, WᵀW = RᵀR, the singular values and the column norms of W are
R's; the rows of several logs reduce log by log where they are treated and their R's stack (``n_obs``: the number
of rows they stand for, for σ̂²). Orthogonal, so no squared condition number (the normal equations' is).
"""

from __future__ import annotations

import numpy as np

__all__ = ["IdentificationError", "instrumental_variables", "least_squares", "rel_stderr_pct", "row_factor"]


class IdentificationError(ValueError):
    """The data do not allow the fit (too few observations, no plateau, no pair); the message says which."""


def row_factor(W, y) -> np.ndarray:
    """The triangular factor R ((min(r, b + 1), b + 1)) of a QR of [W | y] (W (r, b), y (r,)): the compact stand-in
    of the rows in :func:`least_squares` (module docstring); ``R[-1, -1]`` is ± the residual norm of the rows'
    own least squares when r > b."""
    return np.linalg.qr(np.column_stack([np.asarray(W, float), np.asarray(y, float)]), mode="r")


def least_squares(W=None, y=None, weights=None, *, normal=None, at=None, n_obs=None):
    """Least squares with statistics: (x, stderr, sigma2, cov).

    Parameters
    ----------
    W, y : (r, b), (r,) the observation matrix and vector (solved by an orthogonal factorisation, lstsq).
    weights : (r,) > 0, optional: every row of W and y is scaled by √w first (w ∝ 1/variance of the
        observation); σ̂² is then the variance of an observation of unit weight.
    normal : (A, B, C, r) instead of W, y: A = WᵀW (b, b), B = WᵀY (b,), C = YᵀY, r rows (already weighted):
        the sums a streaming pass keeps; x solves A x = B and ‖Y − W x‖² = C − 2 Bᵀx + xᵀA x.
    at : (b,) optional: no solve, the statistics of this estimate (a constrained one: ``--consistent``).
    n_obs : int, optional: the number of observations W, y stand for when they are stacked compact factors
        (:func:`row_factor`) rather than the rows themselves: σ̂² = ‖y − W x̂‖² / (n_obs − b).

    Raises :class:`IdentificationError` when r ≤ b.
    """
    if normal is not None:
        A, B, C, r = normal
        b = B.size
        if r <= b:
            raise IdentificationError(f"{r} rows for {b} parameters: not enough samples")
        x = np.linalg.solve(A, B) if at is None else np.asarray(at, float)
        rss = max(float(C - 2 * B @ x + x @ A @ x), 0.0)
        WtW = A
    else:
        W = np.asarray(W, float)
        y = np.asarray(y, float)
        if weights is not None:
            sw = np.sqrt(np.asarray(weights, float))
            W, y = W * sw[:, None], y * sw
        r, b = W.shape
        r = r if n_obs is None else int(n_obs)
        if r <= b:
            raise IdentificationError(f"{r} rows for {b} parameters: not enough samples")
        x = np.linalg.lstsq(W, y, rcond=None)[0] if at is None else np.asarray(at, float)
        res = y - W @ x
        rss = float(res @ res)
        WtW = W.T @ W
    sigma2 = rss / (r - b)
    cov = sigma2 * np.linalg.inv(WtW)
    return x, np.sqrt(np.diag(cov)), sigma2, cov


def instrumental_variables(W, Z, y, weights=None):
    """Instrumental-variable estimate with statistics: (x, stderr, sigma2, cov) (Janot et al. 2014, IDIM-IV).

    x = (Zᵀ W)⁻¹ Zᵀ y; σ̂² = ‖y − W x‖² / (r − b) (the measured regressor's residual, as :func:`least_squares`);
    C = σ̂² (Zᵀ W)⁻¹ Zᵀ Z (Wᵀ Z)⁻¹, which is σ̂² (WᵀW)⁻¹ when Z = W.

    W, Z : (r, b) the observation matrix (measured, noisy) and the instruments (from a simulation: correlated with
        W, not with its noise); y : (r,); weights : (r,) > 0 as in :func:`least_squares` (rows of W, Z, y scaled
        by √w). Raises :class:`IdentificationError` when r ≤ b.
    """
    W, Z, y = (np.asarray(a, float) for a in (W, Z, y))
    if weights is not None:
        sw = np.sqrt(np.asarray(weights, float))
        W, Z, y = W * sw[:, None], Z * sw[:, None], y * sw
    r, b = W.shape
    if r <= b:
        raise IdentificationError(f"{r} rows for {b} parameters: not enough samples")
    ZW = Z.T @ W
    x = np.linalg.solve(ZW, Z.T @ y)
    res = y - W @ x
    sigma2 = float(res @ res) / (r - b)
    ZWi = np.linalg.inv(ZW)
    cov = sigma2 * ZWi @ (Z.T @ Z) @ ZWi.T
    return x, np.sqrt(np.diag(cov)), sigma2, cov


def rel_stderr_pct(stderr, x) -> np.ndarray:
    """%σ = 100 σ / |x| [%] (S2 eq. 7), elementwise; a value of exactly 0 has an infinite %σ."""
    s = np.asarray(stderr, float)
    a = np.abs(np.asarray(x, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a > 0, 100.0 * s / np.where(a > 0, a, 1.0), np.inf)
