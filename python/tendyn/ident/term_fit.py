"""A position-dependent torque of one joint fitted from a slow sweep log (a cable's or a spring's torque), for a
``known`` ``[[terms]]`` entry of the device file (docs/device-file.md, docs/cli.md ``identify-term``).

A sweep moves one joint slowly one way and back (the dVRK MTM's platform: WPI's ``run_joint_test.py``, constant
|q̇| ≈ 0.4 rad/s); the torque it needs is the position-dependent torque τ_c(q) plus the friction, whose sign
follows the motion: τ = τ_c(q) + F_c sign(q̇) + F_v q̇. At one constant speed F_v q̇ = F_v |q̇| sign(q̇) is not
separable from F_c: one column sign(q̇) takes both, and τ_c is the mean of the two directions (WPI fit each
direction and took the middle curve, data_process.m). τ_c is linear in its coefficients:

* ``polynomial``: τ_c = Σ_{k=0..order} p_k q^k (the constant included: the offset of the sweep);
* ``table``: τ_c linear between ``knots`` (the value at each knot), constant beyond the ends.

One least squares (:func:`tendyn.ident.lsq.least_squares`) gives the coefficients with their σ; samples slower
than ``velocity_fraction`` of the sweep's peak |q̇| (the start, the turn) are left out (the friction's sign is
undefined there).
"""

from __future__ import annotations

import numpy as np

from .lsq import IdentificationError, least_squares, rel_stderr_pct

__all__ = ["TermFit", "KINDS", "DEFAULT_SWEEP_VELOCITY_FRACTION"]

KINDS = ("polynomial", "table")

DEFAULT_SWEEP_VELOCITY_FRACTION = 0.25
"""Samples of a sweep slower than this fraction of its peak |q̇| are left out (start, turn, stops)."""


class TermFit:
    """Fit τ = τ_c(q) + F sign(q̇) on a sweep (estimator contract: fit / predict / score).

    Parameters
    ----------
    kind : "polynomial" or "table"
    order : polynomial order (``polynomial``), 1..12.
    knots : number of knots (``table``), spread evenly over the swept range, ≥ 2.
    velocity_fraction : samples with |q̇| below this fraction of the peak are left out, [0, 1).

    Learned: ``coef_`` (p_0..p_order [N·m/rad^k] or the knot torques [N·m]), ``stderr_``, ``rel_stderr_pct_``,
    ``knots_`` [rad] (``table``), ``friction_`` [N·m] (the sign(q̇) coefficient) and its ``friction_stderr_``,
    ``n_samples_``, ``range_`` (q min, max [rad]), ``residual_rms_`` [N·m], ``curve_stderr_`` [N·m] (the largest
    σ of τ_c(q) over the swept range).
    """

    def __init__(self, kind: str = "polynomial", order: int = 7, knots: int = 20,
                 velocity_fraction: float = DEFAULT_SWEEP_VELOCITY_FRACTION):
        self.kind = kind
        self.order = order
        self.knots = knots
        self.velocity_fraction = velocity_fraction

    def _basis(self, q) -> np.ndarray:
        q = np.asarray(q, float)
        if self.kind == "polynomial":
            return np.column_stack([q ** k for k in range(self.order + 1)])
        from tendyn.device.terms import hat_basis

        return hat_basis(q, self.knots_)

    def fit(self, q, qd, tau) -> "TermFit":
        """q [rad or m], qd [rad/s], tau [N·m] of the swept joint, (n,) each; returns self."""
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)} (got {self.kind!r})")
        q, qd, tau = (np.asarray(x, float).ravel() for x in (q, qd, tau))
        peak = float(np.max(np.abs(qd))) if qd.size else 0.0
        keep = np.abs(qd) >= self.velocity_fraction * peak if peak > 0 else np.zeros(q.size, bool)
        if peak <= 0 or not np.any(qd[keep] > 0) or not np.any(qd[keep] < 0):
            raise IdentificationError("the sweep must move the joint both ways (positive and negative "
                                      "velocities): the friction is told from the position-dependent torque "
                                      "by the two directions")
        q, qd, tau = q[keep], qd[keep], tau[keep]
        self.range_ = (float(q.min()), float(q.max()))
        if self.kind == "table":
            self.knots_ = np.linspace(*self.range_, int(self.knots))
        B = self._basis(q)
        scale = np.maximum(np.max(np.abs(B), axis=0), 1e-300)        # conditioning: q^7 spans 1e3 here
        W = np.column_stack([B / scale, np.sign(qd)])
        x, se, s2, cov = least_squares(W, tau)
        nb = B.shape[1]
        self.coef_, self.stderr_ = x[:nb] / scale, se[:nb] / scale
        self._cov = cov[:nb, :nb] / np.outer(scale, scale)
        self.friction_, self.friction_stderr_ = float(x[nb]), float(se[nb])
        self.rel_stderr_pct_ = rel_stderr_pct(self.stderr_, self.coef_)
        self.n_samples_ = int(q.size)
        self.residual_rms_ = float(np.sqrt(np.mean((tau - W @ x) ** 2)))
        grid = self._basis(np.linspace(*self.range_, 200))
        self.curve_stderr_ = float(np.sqrt(np.max(np.einsum("ij,jk,ik->i", grid, self._cov, grid))))
        return self

    def predict(self, q) -> np.ndarray:
        """τ_c(q) [N·m] (the friction left out)."""
        return self._basis(q) @ self.coef_

    def score(self, q, qd, tau) -> float:
        """RMS of τ − τ_c(q) − F sign(q̇) [N·m] over the moving samples."""
        q, qd, tau = (np.asarray(x, float).ravel() for x in (q, qd, tau))
        keep = np.abs(qd) >= self.velocity_fraction * np.max(np.abs(qd))
        r = tau[keep] - self.predict(q[keep]) - self.friction_ * np.sign(qd[keep])
        return float(np.sqrt(np.mean(r ** 2)))

    def function_text(self) -> str:
        """τ_c as an expression of ``q`` for a ``known`` term (``polynomial``): p_0 + p_1*q + … (Horner-free,
        full precision)."""
        parts = [repr(float(self.coef_[0]))] + [f"({float(c)!r})*q**{k}" for k, c in enumerate(self.coef_) if k]
        return " + ".join(parts)

    def term_toml(self, name: str, joint: int, source: str = "") -> str:
        """The ``[[terms]]`` entry (TOML text): a ``known`` term, with σ and the fit's provenance as comments."""
        lines = [f"# {name}: fitted by tendyn identify-term ({self.kind}"
                 + (f", order {self.order}" if self.kind == "polynomial" else f", {len(self.knots_)} knots")
                 + f") from {source or 'a sweep'}: {self.n_samples_} samples over q in "
                 f"[{self.range_[0]:.4g}, {self.range_[1]:.4g}] rad, friction {self.friction_:.4g} "
                 f"+- {self.friction_stderr_:.2g} N·m (left out), residual RMS {self.residual_rms_:.3g} N·m, "
                 f"largest sigma of the curve {self.curve_stderr_:.3g} N·m",
                 "# sigma of each coefficient (same order): "
                 + ", ".join(f"{s:.3g}" for s in self.stderr_),
                 "[[terms]]", f'name = "{name}"', 'kind = "known"', f"joint = {int(joint)}"]
        if self.kind == "polynomial":
            lines.append(f'function = "{self.function_text()}"')
        else:
            lines.append("knots = [" + ", ".join(repr(float(k)) for k in self.knots_) + "]")
            lines.append("torques = [" + ", ".join(repr(float(c)) for c in self.coef_) + "]")
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict:
        d = {"kind": self.kind, "coef": [float(c) for c in self.coef_], "stderr": [float(s) for s in self.stderr_],
             "rel_stderr_pct": [float(s) for s in self.rel_stderr_pct_], "friction": self.friction_,
             "friction_stderr": self.friction_stderr_, "n_samples": self.n_samples_, "range": list(self.range_),
             "residual_rms": self.residual_rms_, "curve_stderr": self.curve_stderr_}
        if self.kind == "polynomial":
            d["order"] = int(self.order)
        else:
            d["knots"] = [float(k) for k in self.knots_]
        return d
