"""The outcome of an identification of base parameters (S2 Table 4): :class:`IdentificationResult`, and the
warnings for values no physical device can have (:func:`implausible`). Every estimator of :mod:`tendyn.ident`
(IDIM, streaming, closed loop) returns it, so it lives apart from them (no estimator imports another for it)."""

from __future__ import annotations

import numpy as np

from tendyn.results import Result, format_table

from .lsq import rel_stderr_pct
from .model import unit_of

__all__ = ["IdentificationResult", "implausible", "not_physical"]


_MUST_BE_POSITIVE = {"IA": "a rotor inertia", "IAm": "a rotor inertia", "FV": "a viscous coefficient",
                     "FVm": "a viscous coefficient", "FS": "a Coulomb friction", "FSm": "a Coulomb friction"}
"""Stems of the parameters that are physically ≥ 0 on their own (not regrouped: a name without the R)."""


FRICTION_REL_SIGMA_WARN = 0.05
"""σ / |value| of a friction coefficient (FV, FS and their motor-side FVm, FSm) above which the report warns: 2σ
then exceeds 10 % of the value, the data do not pin it to 10 %. Measured (generated parallelogram arms, 20 s
default exciting logs): viscous σ 7-33 % with errors to +60 %; the fast spread-speed design: σ 1.3-4.9 %, errors
within 4.5 % (docs/device-file.md)."""

_FRICTION = ("FV", "FVm", "FS", "FSm")
_UNDETERMINED = "its σ exceeds its value"
_NOT_PINNED = "to 10 %"


def precision_warning(text: str) -> bool:
    """True for a warning of :func:`implausible` that says a value is not pinned by the data (its σ), False for
    one that says it cannot be physical (a negative sign): the consistent fit answers only the second kind."""
    return _UNDETERMINED in text or f" {_NOT_PINNED} (excite" in text


def implausible(names, values, stderr=None, units=None) -> list[str]:
    """Warnings for identified values that cannot be physical: a negative rotor inertia, viscous coefficient or
    Coulomb friction (a base parameter that is one standard parameter alone, ``IA6``, ``FVm6``), named with its
    value, σ, and the fix (the physically consistent estimate); a friction coefficient whose σ exceeds
    :data:`FRICTION_REL_SIGMA_WARN` of its value."""
    out = []
    for i, (n, v) in enumerate(zip(names, values)):
        stem = n.rstrip("0123456789")
        unit = units[i] if units else unit_of(n)
        if stem in _MUST_BE_POSITIVE and v < 0:
            sig = f" (σ {stderr[i]:.2g})" if stderr is not None else ""
            out.append(f"{n} = {v:.4g} {unit}{sig} is negative, which {_MUST_BE_POSITIVE[stem]} cannot be: either "
                       "the data do not determine it (excite that joint more) or the model misses a term; "
                       "--consistent constrains it to be physical")
        elif stem in _MUST_BE_POSITIVE and stderr is not None and abs(stderr[i]) > abs(v):
            out.append(f"{n} = {v:.4g} ± {stderr[i]:.2g} {unit}: {_UNDETERMINED}, so the data do not "
                       f"determine {_MUST_BE_POSITIVE[stem]} (excite that joint faster or longer)")
        elif stem in _FRICTION and stderr is not None and abs(stderr[i]) > FRICTION_REL_SIGMA_WARN * abs(v):
            out.append(f"{n} = {v:.4g} ± {stderr[i]:.2g} {unit}: σ is {100 * abs(stderr[i] / v):.0f} % of it, so "
                       f"the data do not pin {_MUST_BE_POSITIVE[stem]} {_NOT_PINNED} (excite that joint faster, over "
                       "a wider range of speeds, or longer)")
    return out


def not_physical(result) -> bool:
    """True when an identification result cannot be a real device's: a link whose pseudo-inertia no completion
    makes positive (semi)definite, or a negative rotor inertia, viscous or Coulomb coefficient."""
    links = any(not p["ok"] for p in (result.pseudo_inertia or []))
    signs = any(n.rstrip("0123456789") in _MUST_BE_POSITIVE and v < 0 for n, v in zip(result.names, result.values))
    return bool(links or signs)


class IdentificationResult(Result):
    """Identified base parameters with their statistics (S2 Table 4), and measured vs estimated torques."""

    _panels = 1
    _figsize = (8.0, 6.0)

    def __init__(self, device, method, names, expressions, values, stderr, cond, n_rows, residual_rel,
                 per_joint_residual_rel, treatment, time, y, y_hat, rows, joint_numbers, crossval=None,
                 units=None):
        self.device, self.method, self.names, self.expressions = device, method, list(names), list(expressions)
        self.values, self.stderr = np.asarray(values), np.asarray(stderr)
        self.cond, self.n_rows, self.residual_rel = float(cond), int(n_rows), float(residual_rel)
        per_joint = [] if per_joint_residual_rel is None else per_joint_residual_rel
        self.per_joint_residual_rel = [float(v) for v in per_joint]
        self.treatment, self.time, self.y, self.y_hat, self.rows = treatment, time, y, y_hat, rows
        self.joint_numbers = list(joint_numbers)
        self.crossval = crossval
        self.units = list(units) if units is not None else [unit_of(n) for n in self.names]
        self.warnings = implausible(self.names, self.values, self.stderr, self.units)
        self.warnings += list(getattr(treatment, "warnings", []))
        self.omitted: list[str] = []   # base parameters left out on purpose (--essential, --parameters): taken as 0
        self.pseudo_inertia: list[dict] | None = None   # per link: smallest eigenvalue of J, ok (flag_pseudo_inertia)
        self.per_motor_residual_rel: list[float] | None = None   # motor space y = G⁻ᵀ τ (motor_space_residual)
        self.coupled = False          # G is not one motor per joint: the two spaces differ
        self.residual_space = "joint"  # the space of the fitted rows (Treatment.space): residual_rel is in it
        self.closed_loop: dict | None = None   # IDIM-IV / DIDIM: iterations, convergence, the LS start

    def flag_pseudo_inertia(self, model) -> None:
        """Check the links' pseudo-inertias at the identified values (what the data cannot separate at the device
        file's values, :func:`tendyn.ident.consistent.completed_standard`); a link that fails there is checked
        again over every completion (:func:`tendyn.ident.consistent.best_min_eigenvalue`), and a warning is
        added per link whose J cannot be positive (semi)definite: no mass distribution has these parameters."""
        from .consistent import best_min_eigenvalue, completed_standard, pseudo_inertia_check

        self.pseudo_inertia = pseudo_inertia_check(model, completed_standard(model, self.names, self.values))
        bad = [p["link"] for p in self.pseudo_inertia if not p["ok"]]
        if bad:     # the device file's values may be what fails: ask whether any completion is physical (SDP)
            best = dict(zip(bad, best_min_eigenvalue(model, self.names, self.values, bad)))
            for p in self.pseudo_inertia:
                if p["link"] in best:
                    p["min_eigenvalue"], p["ok"] = best[p["link"]], bool(best[p["link"]] >= 0.0)
        for p in self.pseudo_inertia:
            if not p["ok"]:
                self.warnings.append(
                    f"link {p['link']}: pseudo-inertia not positive definite for any choice of the parameters the "
                    f"data cannot separate (smallest eigenvalue reached {p['min_eigenvalue']:.3g} kg·m²): no mass "
                    "distribution has these parameters; --consistent constrains them")

    @property
    def rel_stderr_pct(self) -> np.ndarray:
        return rel_stderr_pct(self.stderr, self.values)

    def to_dict(self) -> dict:
        params = [{"name": n, "value": float(v), "stderr": float(s), "rel_stderr_pct": float(p), "unit": u,
                   "expression": e}
                  for n, v, s, p, e, u in zip(self.names, self.values, self.stderr, self.rel_stderr_pct,
                                              self.expressions, self.units)]
        return {"device": self.device, "method": self.method, "cond": self.cond,
                "cond_scaled": getattr(self, "cond_scaled", None), "n_rows": self.n_rows,
                "residual_rel": self.residual_rel, "per_joint_residual_rel": self.per_joint_residual_rel,
                "residual_space": self.residual_space, "per_motor_residual_rel": self.per_motor_residual_rel,
                "params": params, "omitted": list(self.omitted), "crossval": self.crossval,
                "warnings": list(self.warnings), "pseudo_inertia": self.pseudo_inertia,
                "closed_loop": self.closed_loop,
                "treatment": None if self.treatment is None else self.treatment.to_dict()}

    def table(self) -> str:
        rows = [(n, f"{v:.5g}", u, f"{p:.3g}") for n, v, p, u in zip(self.names, self.values, self.rel_stderr_pct,
                                                                    self.units)]
        text = format_table(("Parameter", "Value", "Unit", "Relative deviation %"), rows,
                            title=f"{self.device}: base parameters ({self.method.upper()}), cond(W) = {self.cond:.4g}"
                                  + (f" ({getattr(self, 'cond_scaled'):.4g} with unit columns)" if getattr(self, "cond_scaled", None) else "")
                                  + ", "
                                  f"W {self.n_rows} x {len(self.names)}")
        motor = self.residual_space == "motor"
        tail = [""]
        if self.per_joint_residual_rel:
            tail.append("relative residual per joint (joint space, tau = G^T y" + ("" if motor else ", the space of the "
                        "fit") + "): " + ", ".join(f"{j}: {100 * r:.2f} %"
                                                  for j, r in zip(self.joint_numbers, self.per_joint_residual_rel)))
        if (self.coupled or motor) and self.per_motor_residual_rel:
            tail.append("relative residual per motor (motor space, y = G^-T tau" + (", the space of the fit"
                        if motor else "") + "): " + ", ".join(
                f"{i}: {100 * r:.2f} %" for i, r in enumerate(self.per_motor_residual_rel, start=1)))
        tail += [
            f"relative residual ||Y - W X|| / ||Y|| ({self.residual_space} space): {100 * self.residual_rel:.2f} %"]
        cl = self.closed_loop
        if cl:
            tail.append(f"closed loop ({cl['controller']}): {cl['iterations']} iterations, "
                        f"{'converged' if cl['converged'] else 'NOT converged'} (|dX|/|X| < {cl['tol']:g}); simulated "
                        f"torque residual {100 * cl['simulated_torque_residual_rel']:.2f} %; least-squares start: "
                        + ", ".join(f"{p['name']} {p['value']:.5g}" for p in cl["ls_start"]))
        if self.crossval:
            per = self.crossval.get("per_joint_residual_rel") or []
            tail.append(f"cross-validation ({self.crossval['fit']} -> {self.crossval['validate']}): relative residual "
                        f"{100 * self.crossval['residual_rel']:.2f} %" + (" (per joint: " + ", ".join(
                            f"{j}: {100 * r:.2f} %" for j, r in zip(self.joint_numbers, per)) + ")" if per else ""))
        if self.treatment is not None:
            tail.append(self.treatment.describe())
        tail += [f"warning: {w}" for w in self.warnings]
        return text + "\n" + "\n".join(tail)

    @property
    def reading(self) -> str:
        """How to read :meth:`plot` (the caption in a report)."""
        if self.y is None or len(self.y) == 0:
            return ("One bar per base parameter: its relative standard deviation %σ on a log scale; a bar above "
                    "100 % is a parameter the data do not determine.")
        return ("One panel per joint: the measured torque (colour) and the torque of the identified model W X "
                "(black dashes) at the same decimated samples; where they part, the model misses that joint's "
                "motion.")

    def _draw(self, ax):
        n = len(self.joint_numbers)
        if self.y is None or len(self.y) == 0:    # a streamed fit keeps no samples: draw the %σ instead
            ax = ax[0] if isinstance(ax, (list, tuple)) else ax
            ax.bar(range(len(self.names)), self.rel_stderr_pct, color="C0")
            ax.set_xticks(range(len(self.names)), self.names, rotation=90, fontsize=6)
            ax.set_yscale("log")
            ax.set_ylabel("relative deviation %σ [%]")
            ax.set_xlabel("base parameter (its unit in the table)")
            ax.set_title(f"{self.device}: base parameters ({self.method})")
            return
        axes = ax if isinstance(ax, (list, tuple)) else [ax]
        for j, num in enumerate(self.joint_numbers[:len(axes)]):
            a, sel = axes[j], self.rows == j
            t = self.time[sel]
            a.plot(t, self.y[sel], lw=0.8, color=f"C{j}", label="measured")
            a.plot(t, self.y_hat[sel], lw=0.8, ls="--", color="k", label="estimated (W X)")
            a.set_ylabel(f"joint {num} torque\n[N·m] (N if prismatic)", fontsize=8)
            a.legend(loc="upper right", fontsize=7)
            a.grid(alpha=0.3)
        axes[-1].set_xlabel("time [s] (decimated samples)")
        axes[0].set_title(f"{self.device}: measured vs estimated joint torques, {n} joints")

    def plot(self, ax=None):
        """One panel per joint (measured and estimated torque over time), or the %σ bars of a streamed fit."""
        if ax is None:
            from tendyn.results import new_figure

            streamed = self.y is None or len(self.y) == 0
            n = 1 if streamed else len(self.joint_numbers)
            _, axes = new_figure(n, 1, figsize=(8.0, 6.0 if streamed else max(2.0 * n, 3.0)), sharex=True)
            ax = axes if n == 1 else list(np.ravel(axes))
        self._draw(ax)
        return (ax[0] if isinstance(ax, (list, tuple)) else ax).figure
