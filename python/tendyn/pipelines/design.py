"""Multi-objective design of a transmission: NSGA-II over a :class:`tendyn.analysis.design_space.DesignSpace`
(issue 32).

Why pymoo's NSGA-II: it is a maintained library (BSD-licensed, on the package index) whose NSGA-II asks for the
objectives of a whole population at once (``elementwise=False``), which is exactly what the batch evaluator
gives; it handles inequality constraints by the constraint-domination rule of Deb (feasible first), and it is
seeded, so a run is reproducible. The motor choice is an index read as ⌊x⌋ of a continuous variable.

A run is ``islands`` independent NSGA-II runs (seeds ``seed``, ``seed + 1``, …) of ``population`` × ``generations``;
their last populations are pooled, evaluated again in one batch and reduced to the non-dominated feasible
designs: the front. Islands are pure functions of plain values (:func:`island`), so they run in this process or
as one Dask task each with the design space shipped once to the workers (``client.scatter(broadcast=True)``):
the front is the same either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from tendyn.analysis.design_space import QUANTITIES, DesignSpace
from tendyn.results import Result, format_table

__all__ = ["DesignResult", "island", "run_design", "non_dominated", "MAX_PAIRS"]

MAX_PAIRS = 6
"""Most objective pairs drawn (panels of the figure)."""


def _signed(F: dict, objectives) -> np.ndarray:
    """(D, m) values to minimise (max objectives negated)."""
    return np.column_stack([F[o] if QUANTITIES[o][1] == "min" else -F[o] for o in objectives])


def _violation(F: dict, constraints) -> np.ndarray:
    """(D, c) g ≤ 0 form of the constraints (NaN counts as violated)."""
    if not constraints:
        return np.zeros((len(next(iter(F.values()))), 0))
    cols = []
    for name, op, bound in constraints:
        v = F[name]
        g = (bound - v) if op == ">=" else (v - bound)
        cols.append(np.where(np.isfinite(g), g, 1e30))
    return np.column_stack(cols)


def non_dominated(Fs: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of Fs (D, m; minimised) that no other row dominates."""
    D = len(Fs)
    keep = np.ones(D, bool)
    for i in range(D):
        if not keep[i]:
            continue
        dom = np.all(Fs <= Fs[i], axis=1) & np.any(Fs < Fs[i], axis=1)
        if dom.any():
            keep[i] = False
    return keep


def island(space: DesignSpace, objectives: Sequence[str], constraints: Sequence, seed: int, population: int,
           generations: int) -> np.ndarray:
    """One seeded NSGA-II run; returns its last population X (population, V). Pure: plain values in and out."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize

    objectives, constraints = list(objectives), list(constraints)
    which = sorted(set(objectives) | {c[0] for c in constraints})

    class _Problem(Problem):
        def __init__(self):
            super().__init__(n_var=len(space.names), n_obj=len(objectives), n_ieq_constr=len(constraints),
                             xl=space.lower, xu=space.upper)

        def _evaluate(self, X, out, *args, **kwargs):
            F = space.evaluate(X, which)
            Fs = _signed(F, objectives)
            out["F"] = np.where(np.isfinite(Fs), Fs, 1e30)
            if constraints:
                out["G"] = _violation(F, constraints)

    res = minimize(_Problem(), NSGA2(pop_size=int(population)), ("n_gen", int(generations)), seed=int(seed),
                   verbose=False, save_history=False)
    return np.asarray(res.pop.get("X"), float)


@dataclass(eq=False)
class DesignResult(Result):
    """The Pareto front of a design run, the shipped design and the chosen one.

    Attributes
    ----------
    device : name; names : design variables; objectives : quantities (``QUANTITIES``); constraints : (name, op, x)
    X : (k, V) front designs; F : {quantity: (k,)} every quantity of each front design
    shipped_x : (V,) the file's design; shipped : {quantity: value} of the file's design
    chosen : index into the front (module :meth:`choose`); values : [{name: value}] per front design
    evaluations : designs evaluated; scheduler : where the islands ran
    """

    device: str
    names: list
    objectives: list
    constraints: list
    X: np.ndarray
    F: dict
    shipped_x: np.ndarray
    shipped: dict
    values: list
    evaluations: int
    scheduler: str = "in process"
    files: list = field(default_factory=list)
    chosen: int = 0

    def __post_init__(self):
        self.chosen = self.choose()

    @property
    def _panels(self):
        return max(1, min(MAX_PAIRS, math.comb(len(self.objectives), 2)))

    _figsize = (4.2, 3.8)
    reading = ("Each panel is one pair of objectives: grey dots are the front designs, the circle the chosen one, "
               "the red star the device file as shipped.")

    def signed(self, F=None) -> np.ndarray:
        return _signed(self.F if F is None else F, self.objectives)

    def dominating(self) -> np.ndarray:
        """Indices of the front designs that dominate the shipped design (better or equal in every objective,
        better in one); empty when the shipped design lies on the front."""
        s = self.signed({k: np.atleast_1d(v) for k, v in self.shipped.items()})[0]
        Fs = self.signed()
        if not np.all(np.isfinite(s)):
            return np.zeros(0, int)
        return np.nonzero(np.all(Fs <= s, axis=1) & np.any(Fs < s, axis=1))[0]

    def shipped_dominates_front(self) -> bool:
        """True when the shipped design dominates a front design (then the front is not a front: a bug)."""
        s = self.signed({k: np.atleast_1d(v) for k, v in self.shipped.items()})[0]
        Fs = self.signed()
        return bool(np.any(np.all(s <= Fs, axis=1) & np.any(s < Fs, axis=1)))

    def improvement(self, i: int | None = None) -> dict:
        """{objective: relative improvement [-] over the shipped design} of front design ``i`` (default the chosen
        one); positive is better (less of a "min" objective, more of a "max" one)."""
        i = self.chosen if i is None else i
        out = {}
        for o in self.objectives:
            s, v = float(self.shipped[o]), float(self.F[o][i])
            sign = 1.0 if QUANTITIES[o][1] == "min" else -1.0
            out[o] = sign * (s - v) / abs(s) if s != 0 and math.isfinite(s) else float("nan")
        return out

    def best_improvement(self) -> dict:
        """{objective: the largest relative improvement any front design makes over the shipped one}."""
        return {o: max(self.improvement(i)[o] for i in range(len(self.X))) for o in self.objectives}

    def choose(self) -> int:
        """The chosen design: among those that dominate the shipped one, the one whose smallest relative
        improvement is largest; otherwise the knee (closest to the ideal point, objectives scaled to [0, 1])."""
        if len(self.X) == 0:
            return 0
        dom = self.dominating()
        if dom.size:
            return int(dom[np.argmax([min(self.improvement(int(i)).values()) for i in dom])])
        Fs = self.signed()
        span = np.ptp(Fs, axis=0)
        Z = (Fs - Fs.min(axis=0)) / np.where(span > 0, span, 1.0)
        return int(np.argmin(np.linalg.norm(Z, axis=1)))

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        pairs = [(a, b) for k, a in enumerate(self.objectives) for b in self.objectives[k + 1:]][:len(axes)]
        if len(self.objectives) == 1:
            pairs = [(self.objectives[0], self.names[0])]
        for a_ax, (a, b) in zip(axes, pairs):
            x = self.F[a]
            y = self.F[b] if b in self.F else self.X[:, 0]
            a_ax.plot(x, y, "o", color="0.5", ms=3, label="front")
            a_ax.plot(x[self.chosen], y[self.chosen], "o", mfc="none", mec="b", ms=10, label="chosen")
            if b in self.shipped:
                a_ax.plot(self.shipped[a], self.shipped[b], "r*", ms=12, label="shipped")
            a_ax.set_xlabel(f"{a} [{QUANTITIES[a][0]}] ({QUANTITIES[a][1]})")
            a_ax.set_ylabel(f"{b} [{QUANTITIES[b][0]}] ({QUANTITIES[b][1]})" if b in QUANTITIES else b)
            a_ax.grid(alpha=0.3)
        axes[0].legend(fontsize=7)
        axes[0].set_title(f"{self.device}: {len(self.X)} front designs")

    def to_dict(self) -> dict:
        def f(v):
            v = float(v)
            return v if math.isfinite(v) else None

        return {"device": self.device, "variables": self.names, "objectives": self.objectives,
                "senses": {o: QUANTITIES[o][1] for o in self.objectives},
                "units": {q: QUANTITIES[q][0] for q in self.F},
                "constraints": [{"quantity": n, "op": op, "bound": b} for n, op, b in self.constraints],
                "front": [{"design": self.values[i], "quantities": {k: f(v[i]) for k, v in self.F.items()},
                           **({"file": self.files[i]} if i < len(self.files) else {})} for i in range(len(self.X))],
                "chosen": self.chosen, "shipped": {"design": {k: float(v) for k, v in zip(self.names, self.shipped_x)},
                                                   "quantities": {k: f(v) for k, v in self.shipped.items()}},
                "shipped_on_or_behind_front": not self.shipped_dominates_front(),
                "dominating_shipped": [int(i) for i in self.dominating()],
                "improvement_chosen": {k: f(v) for k, v in self.improvement().items()} if len(self.X) else {},
                "improvement_best": {k: f(v) for k, v in self.best_improvement().items()} if len(self.X) else {},
                "evaluations": self.evaluations, "scheduler": self.scheduler}

    def table(self) -> str:
        cols = list(self.names) + list(self.objectives)
        rows = []
        for i in range(len(self.X)):
            v = self.values[i]
            rows.append([("*" if i == self.chosen else "") + str(i)] + [v[n] for n in self.names]
                        + [float(self.F[o][i]) for o in self.objectives])
        rows.append(["shipped"] + [float(x) if n != "motor" else "file" for n, x in zip(self.names, self.shipped_x)]
                    + [float(self.shipped[o]) for o in self.objectives])
        text = format_table(["design"] + cols, rows, f"{self.device}: Pareto front ({len(self.X)} designs, "
                                                       f"* = chosen)")
        imp = self.improvement() if len(self.X) else {}
        best = self.best_improvement() if len(self.X) else {}
        lines = [text, "", format_table(["objective", "sense", "shipped", "chosen", "chosen vs shipped",
                                         "best front vs shipped"],
                                        [[o, QUANTITIES[o][1], float(self.shipped[o]), float(self.F[o][self.chosen]),
                                          f"{100 * imp[o]:+.1f} %", f"{100 * best[o]:+.1f} %"]
                                         for o in self.objectives], "improvement over the shipped design")]
        dom = self.dominating()
        lines.append(f"{len(dom)} front design(s) dominate the shipped design" if dom.size else
                     "the shipped design lies on the front (no front design dominates it)")
        return "\n".join(lines)


def _run_islands(space, objectives, constraints, seeds, population, generations, scheduler, n_workers, client,
                 progress):
    if scheduler is None and client is None:
        return [island(space, objectives, constraints, s, population, generations) for s in seeds], "in process"
    from tendyn.pipelines.sweep import dask_client, gather_in_order

    with dask_client(None if scheduler in (None, "local") else scheduler, n_workers, client) as c:
        shipped = c.scatter(space, broadcast=True)           # the compiled design space goes to each worker once
        from tendyn.ident.cluster import placement

        futures = [c.submit(island, shipped, list(objectives), list(constraints), int(s), int(population),
                            int(generations), pure=False, **kw) for s, kw in zip(seeds, placement(c, len(seeds)))]
        pops = gather_in_order(futures, f"{space.device_name}: design", "island", progress)
    where = scheduler if scheduler not in (None, "local") else ("given client" if client is not None
                                                                else f"local ({n_workers} workers)")
    return pops, where


def run_design(space: DesignSpace, objectives: Sequence[str], constraints: Sequence = (), *, population: int = 64,
               generations: int = 60, islands: int = 2, seed: int = 0, scheduler: str | None = None,
               n_workers: int = 2, client=None, progress: bool = False) -> DesignResult:
    """Pareto front of ``objectives`` under ``constraints`` [(quantity, ">="|"<=", bound)] (module docstring).
    ``scheduler``: None in this process, ``"local"`` a local Dask cluster of ``n_workers``, or an address."""
    objectives, constraints = list(objectives), [tuple(c) for c in constraints]
    for q in objectives + [c[0] for c in constraints]:
        why = space.why_not(q)
        if why:
            raise ValueError(why)
    seeds = [seed + k for k in range(islands)]
    pops, where = _run_islands(space, objectives, constraints, seeds, population, generations, scheduler,
                               n_workers, client, progress)
    X = np.unique(np.vstack(pops), axis=0)
    F = space.evaluate(X)
    Fs = _signed(F, objectives)
    feasible = np.all(np.isfinite(Fs), axis=1) & np.all(_violation(F, constraints) <= 0, axis=1)
    X, F, Fs = X[feasible], {k: v[feasible] for k, v in F.items()}, Fs[feasible]
    keep = non_dominated(Fs) if len(X) else np.zeros(0, bool)
    X, F = X[keep], {k: v[keep] for k, v in F.items()}
    order = np.argsort(F[objectives[0]], kind="stable") if len(X) else np.zeros(0, int)
    X, F = X[order], {k: v[order] for k, v in F.items()}
    x0 = space.shipped
    shipped = {k: float(v[0]) for k, v in space.evaluate(x0[None]).items()}
    return DesignResult(space.device_name, list(space.names), objectives, constraints, X, F, x0, shipped,
                        [space.values(x) for x in X], islands * population * (generations + 1), where)
