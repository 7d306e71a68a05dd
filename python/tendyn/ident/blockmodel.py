"""Block-oriented nonlinear models of a bench, fitted by output error (simulation error) to its logs.

A linear block G (discrete transfer function of order n, sample time of the logs) and a static nonlinearity
f (:data:`NONLINEARITIES`, :data:`LURE_NONLINEARITIES`) in one of three arrangements:

* Wiener:      x = G u,  ŷ = f(x)     (S1's dead-band plant, §4.2 and Fig. 8: linear tendon dynamics, then
  the single-valued dead-band of the breakaway friction model, which makes the hysteresis-like loops);
* Hammerstein: v = f(u), ŷ = G v;
* Lur'e:       ŷ = G (u − φ), φ a static nonlinearity of the output's motion fed back to G's input — Coulomb
  friction φ = F sgn(Δŷ) that sticks when it can (:func:`_lure_simulate`). This is where the twins' node
  friction acts (inside the dynamics: it damps the motion), which neither a Wiener nor a Hammerstein model
  can hold (their G absorbs it); the level F [input unit] is the half-width of the dead-band seen from u.

G(z) = (b_0 + b_1 z⁻¹ + … + b_n z⁻ⁿ) / (1 + a_1 z⁻¹ + … + a_n z⁻ⁿ). Each nonlinearity has slope one in its
linear part (dead-zone outside the band, saturation inside, polynomial x + c_2 x² + …), so the gain of the
chain lives in G alone and the parameters are identifiable.

Output error: θ = (b, a, p) minimises Σ_records Σ_t (y_t − ŷ_t(θ))², ŷ simulated from rest over the whole
record (not one step ahead). Wiener and Hammerstein: the simulation is ``scipy.signal.lfilter`` (compiled)
and so is the exact Jacobian: ∂x/∂b_k = (z⁻ᵏ/A) u, ∂x/∂a_k = −(z⁻ᵏ/A) x — two filters per record for all of
(b, a) — chained through f′ (Wiener) or filtered through G (the nonlinearity's parameters in Hammerstein
form). The minimiser is Levenberg–Marquardt (:func:`_solve`, bounds on the thresholds) started from a
linear initial estimate: ARX least squares, refined to linear output error, then the nonlinearity's
parameters by linear least squares over a grid of thresholds (the gain of G rescaled at the same time).
Lur'e: the stick/slip choice of each sample depends on the simulated output, so the simulation is one
scalar recursion (:func:`_lure_simulate`) and the Jacobian is by forward differences; G is strictly proper
(b_0 = 0, the friction of sample t acts from sample t + 1 on); the initial estimate is equation error with
the friction's sign read from the measured output (:func:`_initial_lure`), exact at no noise (a linear
output-error G has its damping inflated by the friction; from it the McGill twin's fit ends at a higher
cost, docs/bench-identification.md).

``coulomb-tension`` (Lur'e, push-pull): the level of each branch F + μ s y grows with its output (a node's friction
linear in its tendon's tension, S1 §4) and the recursion runs :data:`LURE_SUBSTEPS` steps a sample on G's
continuous equivalent re-sampled (:func:`_fine`), so stick/slip is decided 4× finer than the log rate: a model
fitted at one amplitude then holds at 0.5× and 1.5× of it within 1.2× its NRMS on generated benches, where the
constant level at the log rate reached 1.35× (docs/bench-identification.md).

RMS [output unit] and NRMS = ‖y − ŷ‖/‖y − ȳ‖ [-] (1: no better than the mean) are reported on the fit and
on validation records. :class:`BlockModel` is the estimator (hyper-parameters in ``__init__``, learned values
with a trailing ``_``, ``fit`` / ``predict`` / ``score``); its ``result_`` a :class:`BlockModelFit`.

The parts, one job each: :mod:`~tendyn.ident.block_nonlinearities` (the static nonlinearities, which structure
takes which), :mod:`~tendyn.ident.block_records` (records from logs, NRMS), :mod:`~tendyn.ident.block_simulation`
(G, the chains, the Lur'e recursions) and :mod:`~tendyn.ident.block_solver` (residuals, Levenberg–Marquardt,
starting points); this module holds the estimator and its result and re-exports the parts' public names.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.results import Result, format_table

from .block_nonlinearities import IDENTITY, LURE_STRUCTURES, STRUCTURES, Nonlinearity, nonlinearity
from .block_records import Record, _as_records, nrms
from .block_simulation import simulate
from .block_solver import (LURE_TOL, _abs_sign_recovery, _arx, _initial_lure, _initial_nonlinear, _solve, _Solution,
                           _stabilise)

# the parts' public names, re-exported (``from tendyn.ident.blockmodel import X`` keeps working)
from .block_nonlinearities import (LURE_NONLINEARITIES, LURE_SUBSTEPS, NONLINEARITIES,  # noqa: F401,E402
                                   NONLINEARITY_NAMES, polynomial)
from .block_records import records_from_logs  # noqa: F401,E402

__all__ = ["LURE_NONLINEARITIES", "NONLINEARITIES", "STRUCTURES", "BlockModel", "BlockModelFit", "Nonlinearity",
           "Record", "nrms", "records_from_logs", "simulate"]

AUTO_CANDIDATES = (("wiener", "dead-zone"), ("lure", "coulomb"), ("push-pull", "coulomb"),
                   ("push-pull", "coulomb-tension"))
"""(structure, nonlinearity) pairs tried by ``BlockModel("auto")`` (chosen by the validation NRMS)."""


@dataclass(eq=False)
class BlockModelFit(Result):
    """A fitted Wiener, Hammerstein or Lur'e model: G(z) = B/A at ``dt`` [s], the nonlinearity and its parameters,
    RMS [output unit] and NRMS [-] on the fit and validation records, NRMS per order tried."""

    structure: str
    nonlinearity: str
    order: int
    b: np.ndarray
    a: np.ndarray
    params: dict
    dt: float
    fit_rms: float
    fit_nrms: float
    validation_rms: list = field(default_factory=list)
    validation_nrms: list = field(default_factory=list)
    order_nrms: dict = field(default_factory=dict)
    units: dict = field(default_factory=lambda: {"input": "-", "output": "-"})
    nfev: int = 0
    seconds: float = 0.0
    structure_nrms: dict = field(default_factory=dict)     # "structure nonlinearity" → validation NRMS (auto)
    example: tuple | None = field(default=None, repr=False)     # (title, time, y, ŷ) of one record, ≤ 2 s

    def linear_tf(self):
        """G(z) as a python-control discrete ``TransferFunction`` (dt [s])."""
        import control

        b = np.where(np.abs(self.b) < 1e-12 * np.abs(self.b).max(), 0.0, self.b)   # a round-off b_0 is a delay
        return control.tf(b, np.concatenate([[1.0], self.a]), self.dt)

    def linear_continuous(self):
        """G(s) with the same zero-order-hold samples as G(z) (matrix logarithm of the sampled state
        space), as a python-control ``TransferFunction``. Raises ValueError if a pole of G(z) lies on the
        negative real axis (no real continuous equivalent)."""
        import control
        from scipy.linalg import expm, logm

        sysd = control.ss(self.linear_tf())
        nx = sysd.A.shape[0]
        poles = np.linalg.eigvals(sysd.A)
        if np.any((np.abs(poles.imag) < 1e-12) & (poles.real <= 0)):
            raise ValueError("a pole of G(z) lies on the non-positive real axis: no continuous equivalent")
        M = np.zeros((nx + 1, nx + 1))
        M[:nx, :nx], M[:nx, nx:] = sysd.A, sysd.B
        M[nx, nx] = 1.0
        L = np.real(logm(M)) / self.dt
        assert np.allclose(expm(L * self.dt), M, atol=1e-8 * np.abs(M).max())
        return control.tf(control.ss(L[:nx, :nx], L[:nx, nx:], sysd.C, sysd.D))

    def frequency_response(self, omega) -> np.ndarray:
        """G(e^{jωdt}) on ``omega`` [rad/s]."""
        z = np.exp(1j * np.asarray(omega, float) * self.dt)
        zi = 1.0 / z
        num = np.polyval(self.b[::-1], zi)
        den = np.polyval(np.concatenate([[1.0], self.a])[::-1], zi)
        return num / den

    def predict(self, u) -> np.ndarray:
        nl = nonlinearity(self.nonlinearity, len(self.params) + 1, self.structure)
        return simulate(self.structure, nl, self.b, self.a, np.array(list(self.params.values()), float),
                        np.asarray(u, float))

    reading = ('The measured output and the fitted block model simulated from rest over the same input; where the '
               'dashed curve leaves the measured one, the model misses the dynamics.')

    def _draw(self, ax) -> None:
        if self.example is None:
            ax.text(0.5, 0.5, "no validation record", ha="center")
            return
        title, t, y, yh = self.example
        ax.plot(t, y, lw=1.0, label="measured")
        ax.plot(t, yh, lw=1.0, ls="--", label=f"simulated from rest ({self.structure}, {self.nonlinearity})")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"output [{self.units['output']}]")
        ax.set_title(title)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)

    def to_dict(self) -> dict:
        d = {"structure": self.structure, "nonlinearity": self.nonlinearity, "order": self.order,
             "b": [float(v) for v in self.b], "a": [1.0] + [float(v) for v in self.a], "dt_s": self.dt,
             "nonlinearity_params": {k: float(v) for k, v in self.params.items()},
             "fit_rms": self.fit_rms, "fit_nrms": self.fit_nrms, "validation_rms": list(self.validation_rms),
             "validation_nrms": list(self.validation_nrms),
             "order_nrms": {str(k): v for k, v in self.order_nrms.items()}, "units": dict(self.units),
             "nfev": self.nfev, "seconds": self.seconds,
             "structure_nrms": dict(self.structure_nrms)}
        try:
            G = self.linear_continuous()
            d["continuous"] = {"num": [float(v) for v in np.ravel(G.num[0][0])],
                               "den": [float(v) for v in np.ravel(G.den[0][0])]}
        except ValueError:
            d["continuous"] = None
        return d

    def table(self) -> str:
        rows = [(k, v) for k, v in self.params.items()]
        rows += [("fit RMS [" + self.units["output"] + "]", self.fit_rms), ("fit NRMS", self.fit_nrms)]
        rows += [(f"validation {i + 1} NRMS", v) for i, v in enumerate(self.validation_nrms)]
        rows += [(f"order {k}: NRMS", v) for k, v in self.order_nrms.items()]
        rows += [(f"{k}: validation NRMS", v) for k, v in self.structure_nrms.items()]
        return format_table(("quantity", "value"), rows,
                            f"{self.structure} model, {self.nonlinearity}, order {self.order} "
                            f"({self.nfev} evaluations, {self.seconds:.2f} s)")


class BlockModel:
    """Estimator of a Wiener, Hammerstein or Lur'e model by output error (module docstring).

    Parameters (hyper-parameters, stored as given)
    ----------
    structure : {"wiener", "hammerstein", "lure", "push-pull", "auto"}
        ``push-pull``: two Lur'e loops of one G and one friction level fed max(u, 0) and min(u, 0), outputs added
        (a class-B 2N drive, :func:`_push_pull_simulate`); ``auto``: each of :data:`AUTO_CANDIDATES` fitted, the
        lowest mean NRMS on the validation records kept (``nonlinearity`` is then not used).
    nonlinearity : str
        One of ``dead-zone`` (alias ``dead-band``), ``coulomb``, ``saturation``, ``abs``, ``polynomial``;
        ``lure``: ``coulomb`` (friction of level ``params_["level"]`` [input unit] in G's feedback).
    order : int or None
        Order n of G(z); None chooses it in 1…``max_order`` by the NRMS on the validation records (or, without
        them, on the last third of each fit record, the model fitted on the first two thirds), then refits.
    max_order : int
    degree : int
        Degree of the polynomial nonlinearity.
    skip : int
        Samples at the start of each record left out of the cost (an initial state that is not rest).
    max_nfev : int
        Evaluations allowed to the output-error minimiser per fit.
    rate_hz : float or None
        Sample rate [Hz] of records given as (u, y) arrays (records from logs carry their own).

    Learned attributes
    ------------------
    order_ : int;  b_, a_ : the coefficients of G(z) (``a_`` without its leading 1);  params_ : dict of the
    nonlinearity's parameters [its input's unit];  dt_ : [s];  linear_ : G(z) (python-control);
    structure_, nonlinearity_ : the fitted structure (``auto``: the chosen one);  structure_nrms_ : {"structure
    nonlinearity": validation NRMS} (``auto``);  fit_rms_, fit_nrms_ ;  validation_nrms_ : list;  order_nrms_ : {order: NRMS};  nfev_ ;  result_ :
    :class:`BlockModelFit`.
    """

    def __init__(self, structure: str = "wiener", nonlinearity: str = "dead-zone", order: int | None = None,
                 max_order: int = 4, degree: int = 3, skip: int = 0, max_nfev: int = 200,
                 rate_hz: float | None = None):
        self.structure = structure
        self.nonlinearity = nonlinearity
        self.order = order
        self.max_order = max_order
        self.degree = degree
        self.skip = skip
        self.max_nfev = max_nfev
        self.rate_hz = rate_hz

    def get_params(self, deep: bool = True) -> dict:
        return {k: getattr(self, k) for k in ("structure", "nonlinearity", "order", "max_order", "degree", "skip",
                                              "max_nfev", "rate_hz")}

    # ---- fitting ----
    def _nl(self) -> Nonlinearity:
        if self.structure == "auto":
            return nonlinearity(self.nonlinearity_, self.degree, self.structure_)
        return nonlinearity(self.nonlinearity, self.degree, self.structure)

    def _fit_order(self, records, n, warm=None):
        """θ and evaluations of the order-n model; ``warm``, the order n − 1 solution, is also tried padded
        with a pole and a zero at the origin (the same model), so a higher order never fits worse."""
        nl = self._nl()
        starts = []
        if self.structure in LURE_STRUCTURES and nl.name == "coulomb-tension":
            # the constant-level model first (its G and F), then μ = 0 added and all refined on the fine steps
            th0, nf0 = BlockModel(self.structure, "coulomb", order=n, skip=self.skip,
                                  max_nfev=self.max_nfev)._fit_order(records, n, warm=None if warm is None
                                                                     else warm[:-1])
            b, a, p = th0[:n + 1], th0[n + 1:2 * n + 1], np.concatenate([th0[2 * n + 1:], [0.0]])
        elif self.structure in LURE_STRUCTURES:
            b, a, p = _initial_lure(n, records)
            if self.structure == "push-pull":
                # the one-loop Lur'e model by output error first: its G is the push-pull's, its level the
                # dead-band of both branches (≈ 2 F at rest) or of one; both starts are tried
                one = _solve("lure", nl, n, np.concatenate([b, a, p]), records, self.skip, self.max_nfev,
                             np.array(nl.lower, float), LURE_TOL)
                b, a, p = one.x[:n + 1], one.x[n + 1:2 * n + 1], one.x[2 * n + 1:]
                starts.append(np.concatenate([b, a, p / 2]))
        elif self.structure == "wiener" and nl.name == "abs":
            b, a = _abs_sign_recovery(records, n, self.skip, self.max_nfev)
        else:   # linear output error (identity in place of f) from ARX
            b, a = _arx(records, n)
            sol = _solve("wiener", IDENTITY, n, np.concatenate([b, a]), records, self.skip, self.max_nfev,
                         np.zeros(0))
            b, a = sol.x[:n + 1], _stabilise(sol.x[n + 1:2 * n + 1])
        if self.structure not in LURE_STRUCTURES:
            b, p = _initial_nonlinear(self.structure, nl, n, b, a, records, self.degree - 1)
        tol = LURE_TOL if self.structure in LURE_STRUCTURES else 1e-10
        sol = _solve(self.structure, nl, n, np.concatenate([b, a, p]), records, self.skip, self.max_nfev,
                     np.array(nl.lower, float), tol)
        if warm is not None:
            starts.append(np.concatenate([warm[:n], [0.0], warm[n:2 * n - 1], [0.0], warm[2 * n - 1:]]))
        for start in starts:
            other = _solve(self.structure, nl, n, start, records, self.skip, self.max_nfev, np.array(nl.lower, float),
                           tol)
            if other.cost < sol.cost:
                sol = _Solution(other.x, other.cost, other.nfev + sol.nfev)
        theta = sol.x
        if self.structure == "wiener" and nl.name == "abs" and np.sum(theta[:n + 1]) < 0:
            theta = np.concatenate([-theta[:n + 1], theta[n + 1:]])     # |G u| = |−G u|: G(1) > 0 by convention
        return theta, sol.nfev

    def fit(self, records, validation=None) -> "BlockModel":
        """Fit to records: a :class:`Record`, a ``(u, y)`` pair or a list of either (``rate_hz`` needed for
        arrays); ``validation`` the same kinds. Returns self."""
        import time

        if self.structure == "auto":
            return self._fit_auto(records, validation)
        if self.structure not in STRUCTURES:
            raise ValueError(f"structure must be one of {STRUCTURES} or 'auto' (got {self.structure!r})")
        nl = self._nl()
        self.structure_, self.nonlinearity_ = self.structure, nl.name
        self.structure_nrms_ = {}
        recs = _as_records(records, self.rate_hz)
        val = _as_records(validation, self.rate_hz) if validation is not None else []
        rates = {r.rate_hz for r in recs + val}
        if len(rates) != 1 or None in rates:
            raise ValueError(f"all records need one sample rate (got {sorted(map(str, rates))})")
        if self.order is not None and (int(self.order) < 1 or int(self.order) > 12):
            raise ValueError(f"order must be 1…12 (got {self.order!r})")
        t0 = time.perf_counter()
        self.order_nrms_ = {}
        if self.order is None:
            if val:
                sel_fit, sel_val = recs, val
            else:
                sel_fit = [Record(r.u[:2 * r.u.size // 3], r.y[:2 * r.y.size // 3], r.rate_hz) for r in recs]
                sel_val = [Record(r.u[2 * r.u.size // 3:], r.y[2 * r.y.size // 3:], r.rate_hz) for r in recs]
            fits = {0: (None, 0)}
            for n in range(1, int(self.max_order) + 1):
                fits[n] = self._fit_order(sel_fit, n, warm=fits[n - 1][0])
                self._set(fits[n][0], n, nl, recs[0].rate_hz)
                self.order_nrms_[n] = float(np.mean([self.nrms(r.u, r.y) for r in sel_val]))
            n = min(self.order_nrms_, key=lambda k: (round(self.order_nrms_[k], 3), k))
            # with validation records the selection fitted on all the fit records already
            th, nfev = fits[n] if val else self._fit_order(recs, n, warm=fits[n - 1][0])
        else:
            n = int(self.order)
            th, nfev = self._fit_order(recs, n)
        self._set(th, n, nl, recs[0].rate_hz)
        self.nfev_ = int(nfev)
        yh = [self.predict(r.u) for r in recs]
        err = np.concatenate([(y - r.y)[self.skip:] for y, r in zip(yh, recs)])
        ally = np.concatenate([r.y[self.skip:] for r in recs])
        self.fit_rms_ = float(np.sqrt(np.mean(err ** 2)))
        self.fit_nrms_ = float(np.linalg.norm(err) / np.linalg.norm(ally - ally.mean()))
        self.validation_rms_ = [self.rms(r.u, r.y) for r in val]
        self.validation_nrms_ = [self.nrms(r.u, r.y) for r in val]
        k = int(np.argmin(self.validation_nrms_)) if val else 0     # the validation record the model fits best
        ex = val[k] if val else recs[0]
        m = min(ex.u.size, int(2.0 * ex.rate_hz))
        title = (f"validation record {k + 1} of {len(val)}: NRMS {self.validation_nrms_[k]:.3f} (first {m / ex.rate_hz:g} s)"
                 if val else f"fit: NRMS {self.fit_nrms_:.3f}")
        example = (title, np.arange(m) / ex.rate_hz, ex.y[:m], self.predict(ex.u)[:m])
        self.result_ = BlockModelFit(self.structure, nl.name, n, self.b_.copy(), self.a_.copy(), dict(self.params_),
                                     self.dt_, self.fit_rms_, self.fit_nrms_, self.validation_rms_,
                                     self.validation_nrms_, dict(self.order_nrms_), nfev=self.nfev_,
                                     seconds=time.perf_counter() - t0, example=example)
        return self

    def _fit_auto(self, records, validation):
        """Structure chosen by the validation NRMS (mean over the validation records) among
        :data:`AUTO_CANDIDATES`, each with its order chosen as ``order`` says; the winner's learned values."""
        import time

        t0 = time.perf_counter()
        best, table = None, {}
        for st, nl in AUTO_CANDIDATES:
            m = BlockModel(**(self.get_params() | {"structure": st, "nonlinearity": nl}))
            m.fit(records, validation)
            score = (float(np.mean(m.validation_nrms_)) if m.validation_nrms_
                     else float(min(m.order_nrms_.values())) if m.order_nrms_ else m.fit_nrms_)
            table[f"{st} {nl}"] = score
            if best is None or score < best[0]:
                best = (score, m)
        m = best[1]
        for k, v in vars(m).items():
            if k.endswith("_"):
                setattr(self, k, v)
        self.structure_nrms_ = table
        self.result_.structure_nrms = dict(table)
        self.result_.seconds = time.perf_counter() - t0
        return self

    def _set(self, theta, n, nl, rate_hz):
        self.order_ = n
        self.b_ = np.asarray(theta[:n + 1], float)
        self.a_ = np.asarray(theta[n + 1:2 * n + 1], float)
        self.params_ = {k: float(v) for k, v in zip(nl.params, theta[2 * n + 1:])}
        self.dt_ = 1.0 / float(rate_hz)

    @property
    def linear_(self):
        return self.result_.linear_tf()

    # ---- using the model ----
    def predict(self, u) -> np.ndarray:
        """ŷ [output unit] simulated from rest for the input ``u``."""
        return simulate(self.structure_, self._nl(), self.b_, self.a_, np.array(list(self.params_.values()), float),
                        np.asarray(u, float))

    def rms(self, u, y) -> float:
        """RMS of y − ŷ [output unit] (after ``skip``)."""
        e = (np.asarray(y, float) - self.predict(u))[self.skip:]
        return float(np.sqrt(np.mean(e ** 2)))

    def nrms(self, u, y) -> float:
        """NRMS = ‖y − ŷ‖/‖y − ȳ‖ [-] (after ``skip``)."""
        y = np.asarray(y, float)
        return nrms(y[self.skip:], self.predict(u)[self.skip:])

    def score(self, u, y) -> float:
        """1 − NRMS [-] (1 perfect, 0 no better than the mean; higher is better, as scikit-learn's score)."""
        return 1.0 - self.nrms(u, y)
