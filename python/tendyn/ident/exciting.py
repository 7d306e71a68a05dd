"""Exciting trajectories for a real bench (issue 18 item 7): a finite Fourier series per joint whose
coefficients minimise cond(W) of the base regressor, inside the joint, speed and motor-torque limits.

q_j(t) = c_j + Σ_{l=1..L} a_jl / (l ω) sin(l ω t) − b_jl / (l ω) cos(l ω t), ω = 2π f₀ (Swevers, Ganseman,
Tükel, De Schutter, Van Brussel 1997): periodic with period 1/f₀, so the samples of several periods can be
averaged; q̇ = Σ a cos + b sin, q̈ = Σ l ω (b cos − a sin). The first harmonic's coefficients are set so that
q̇(0) = q̈(0) = 0 (a bench starts at rest): a_j1 = −Σ_{l≥2} a_jl, b_j1 = −Σ_{l≥2} l b_jl.

Optimisation: a (1+1) evolution strategy (one-fifth success rule, seeded) on the coefficients; each candidate is
first scaled into the limits (excursion and speed scale linearly with the coefficients; the motor torques of
the device file's model, τ = W(q, q̇, q̈) X_prior, motor side y = G⁻ᵀ τ, are brought under the motors' peak
torque by shrinking further), then scored by cond(W) of the base regressor with unit-norm columns (raw cond(W)
mixes units: kg·m² against N·m columns). Both are reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FourierDesign", "ExcitingPlan", "plan_exciting", "friction_column_share"]


@dataclass(frozen=True)
class FourierDesign:
    """A finite Fourier series per active joint: ``center`` (n_a,) [rad or m], ``base_hz`` f₀ [Hz], ``a``, ``b``
    (n_a, L) [rad/s or m/s] (module docstring)."""

    center: np.ndarray
    base_hz: float
    a: np.ndarray
    b: np.ndarray

    @property
    def period(self) -> float:
        return 1.0 / self.base_hz

    def references(self, duration: float, dt: float):
        """(q, q̇, q̈) (n, n_a) sampled every ``dt`` [s] over ``duration`` [s]."""
        t = np.arange(int(round(duration / dt))) * dt
        return self.at(t)

    def at(self, t):
        w = 2 * np.pi * self.base_hz
        L = self.a.shape[1]
        lw = w * np.arange(1, L + 1)                     # (L,)
        s, c = np.sin(np.outer(t, lw)), np.cos(np.outer(t, lw))   # (n, L)
        q = self.center + s @ (self.a / lw).T - c @ (self.b / lw).T
        qd = c @ self.a.T + s @ self.b.T
        qdd = (c * lw) @ self.b.T - (s * lw) @ self.a.T
        return q, qd, qdd

    def to_dict(self) -> dict:
        return {"kind": "fourier", "center": [float(v) for v in self.center], "base_hz": float(self.base_hz),
                "a": self.a.tolist(), "b": self.b.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> "FourierDesign":
        return cls(np.asarray(d["center"], float), float(d["base_hz"]), np.asarray(d["a"], float),
                   np.asarray(d["b"], float))


def _at_rest(a, b):
    """The coefficients with the first harmonic set for q̇(0) = q̈(0) = 0."""
    a, b = a.copy(), b.copy()
    L = a.shape[1]
    a[:, 0] = -a[:, 1:].sum(axis=1)
    b[:, 0] = -(b[:, 1:] * np.arange(2, L + 1)).sum(axis=1)
    return a, b


@dataclass
class ExcitingPlan:
    """The optimised trajectory and what it achieves: ``design``; ``cond`` and ``cond_scaled`` of the base
    regressor on one period (raw, unit-norm columns) before (``*_initial``) and after; ``limits`` (per joint:
    range [rad or m], speed [rad/s or m/s], peak motor torque [N·m] or None) and ``peaks`` reached; ``why``."""

    design: FourierDesign
    cond: float
    cond_scaled: float
    cond_initial: float
    cond_scaled_initial: float
    limits: dict
    peaks: dict
    evaluations: int
    why: list

    def to_dict(self) -> dict:
        return {"design": self.design.to_dict(), "cond": self.cond, "cond_scaled": self.cond_scaled,
                "cond_initial": self.cond_initial, "cond_scaled_initial": self.cond_scaled_initial,
                "limits": self.limits, "peaks": self.peaks, "evaluations": self.evaluations, "why": list(self.why)}

    def table(self) -> str:
        from tendyn.results import format_table

        lim, pk = self.limits, self.peaks
        rows = []
        for k in range(len(lim["lower"])):
            tl = lim["peak_motor_torque"][k] if lim["peak_motor_torque"] else None
            rows.append((k + 1, f"[{lim['lower'][k]:.3g}, {lim['upper'][k]:.3g}]",
                         f"[{pk['q_min'][k]:.3g}, {pk['q_max'][k]:.3g}]", f"{lim['max_speed'][k]:.3g}",
                         f"{pk['speed'][k]:.3g}", "-" if tl is None else f"{tl:.3g}",
                         "-" if pk["motor_torque"] is None else f"{pk['motor_torque'][k]:.3g}"))
        return format_table(("Axis", "Limits", "Range used", "Max speed", "Speed", "Peak torque", "Torque"), rows,
                            title=f"exciting trajectory: Fourier series, f0 = {self.design.base_hz:g} Hz, "
                                  f"{self.design.a.shape[1]} harmonics; cond(W) = {self.cond:.4g} "
                                  f"({self.cond_scaled:.4g} with unit columns; {self.cond_scaled_initial:.4g} "
                                  f"before optimisation)") + "\n" + "\n".join(f"why: {w}" for w in self.why)

    def reference_log(self, duration: float, rate_hz: float, device_name: str):
        """The references as a log (``time``, ``q_ref_<k>``, ``qd_ref_<k>`` per active axis; ``options.design``
        holds the series, so :meth:`FourierDesign.from_dict` rebuilds it, accelerations included)."""
        from tendyn.io import make_log

        q, qd, qdd = self.design.references(duration, 1.0 / rate_hz)
        cols = {"time": np.arange(q.shape[0]) / rate_hz}
        for name, x in (("q_ref_", q), ("qd_ref_", qd)):
            for k in range(x.shape[1]):
                cols[f"{name}{k + 1}"] = x[:, k]
        opts = {"design": self.design.to_dict(), "cond": self.cond, "cond_scaled": self.cond_scaled,
                "space": "joint", "note": "track q_ref_<k> on active joint k (file order of the active joints)"}
        return make_log(cols, device=device_name, rate_hz=rate_hz, seed=None, experiment="plan_exciting",
                        options=opts)


def friction_column_share(device, q, qd, qdd, velocity_threshold: float = 0.2) -> dict[str, float]:
    """How well a trajectory tells each friction parameter apart: for every Coulomb (``FS<j>``) and viscous
    (``FV<j>``) column of the base regressor, the norm of its unit-norm column's part that the other base columns
    do not explain (least squares): 1 = orthogonal to all of them, 0 = a combination of them (not identifiable).
    σ of that parameter scales as 1 / share for a given noise. Rows where |q̇| < ``velocity_threshold`` [rad/s]
    are left out, as IDIM leaves them out (:func:`tendyn.ident.treatment.above_threshold`).

    q, qd, qdd : (n, n_active) [rad], [rad/s], [rad/s²], e.g. a design's references at the decimated rate.
    A single cruise speed per joint makes F_C sign(q̇) and F_V q̇ nearly proportional (share ≈ 0.24 on a desktop
    capstan arm's base joint); ``design_exciting(…, speed_span=0.8)`` spreads the speeds (share ≈ 0.48)."""
    import re

    from .model import cached_model
    from .treatment import above_threshold

    model = cached_model(device)
    W = model.regressor(np.asarray(q, float), np.asarray(qd, float), np.asarray(qdd, float),
                        threads=1)[:, list(model.base.columns)]
    W = W[above_threshold(qd, velocity_threshold).T.ravel()]
    n = np.linalg.norm(W, axis=0)
    W = W / np.where(n > 0, n, 1.0)
    out = {}
    for i, name in enumerate(model.base.names):
        if re.fullmatch(r"F[SV]\d+", name):
            others = np.delete(W, i, axis=1)
            r = W[:, i] - others @ np.linalg.lstsq(others, W[:, i], rcond=None)[0]
            out[name] = float(np.linalg.norm(r))
    return out


def plan_exciting(device, harmonics: int = 5, base_hz: float | None = None, max_speed: float = 1.5,
                  margin: float = 0.05, iterations: int = 300, samples: int = 120, seed: int = 0) -> ExcitingPlan:
    """Optimise a Fourier exciting trajectory for a device (module docstring).

    Parameters
    ----------
    harmonics : L, number of harmonics per joint.
    base_hz : f₀ [Hz]; default 0.2 Hz, lowered so that L f₀ stays at or below half the device's bandwidth_hz.
    max_speed : speed limit per axis [rad/s, m/s at a prismatic joint] (device files give none).
    margin : fraction of each joint's range kept free at both ends.
    iterations : candidates of the evolution strategy.
    samples : samples of one period in W.
    """
    from tendyn.device import compile_device

    from .model import cached_model

    compiled = compile_device(device)
    model = cached_model(compiled)
    dev = model.device
    na = model.n_active
    why = []
    bw = getattr(dev, "bandwidth_hz", None)
    if base_hz is None:
        base_hz = 0.2
        if bw and harmonics * base_hz > 0.5 * bw:
            base_hz = 0.5 * bw / harmonics
            why.append(f"f0 = {base_hz:.3g} Hz so that the highest harmonic ({harmonics} f0) is half the device's "
                       f"bandwidth ({bw:g} Hz)")
        else:
            why.append(f"f0 = {base_hz:g} Hz (default), highest harmonic {harmonics * base_hz:g} Hz"
                       + (f", below half the device's bandwidth {bw:g} Hz" if bw else ""))
    else:
        why.append("f0 given")
    lo, hi = model._ranges()
    span = hi - lo
    lo_m, hi_m = lo + margin * span, hi - margin * span
    center = 0.5 * (lo_m + hi_m)
    room = 0.5 * (hi_m - lo_m)
    vmax = np.full(na, float(max_speed))
    peak = None
    if dev.transmissions or dev.drives:
        motors = [t.motor for t in (dev.transmissions or dev.drives)]
        peak = np.array([m.peak_torque for m in motors])
        why.append("motor torques within each motor's peak_torque (device file), computed with the file's model")
    else:
        why.append("no motor torque limit: the device file gives no peak torque for [[actuators]]")
    why.append(f"speeds within {max_speed:g} rad/s (m/s), positions within the joint limits less {100 * margin:g} %")
    prior = model.prior()
    Ginv_T = np.linalg.inv(model.G).T
    t = np.arange(samples) / (samples * base_hz)
    nc = 64 * harmonics                          # limits checked on a grid fine for the highest harmonic
    tc = np.arange(nc) / (nc * base_hz)
    cols = list(model.base.columns)

    def project(a, b):
        a, b = _at_rest(a, b)
        d = FourierDesign(center, base_hz, a, b)
        q, qd, _ = d.at(tc)
        exc = np.max(np.abs(q - center), axis=0)
        s = 0.995 * min(1.0, float(np.min(room / np.maximum(exc, 1e-12))),     # 0.5 % for between grid points
                        float(np.min(vmax / np.maximum(np.max(np.abs(qd), axis=0), 1e-12))))
        d = FourierDesign(center, base_hz, s * a, s * b)
        if peak is None:
            return d
        for _ in range(60):
            if np.all(np.max(np.abs(_motor_torque(d)), axis=0) <= peak):
                return d
            d = FourierDesign(center, base_hz, 0.85 * d.a, 0.85 * d.b)
        return FourierDesign(center, base_hz, 0.0 * a, 0.0 * b)   # at rest: checked below

    def _motor_torque(d):
        q, qd, qdd = d.at(tc)
        tau = (model.regressor(q, qd, qdd, threads=1) @ prior).reshape(na, -1).T
        return tau @ Ginv_T

    if peak is not None:        # holding the centre pose must be possible at all
        still = np.max(np.abs(_motor_torque(FourierDesign(center, base_hz, np.zeros((na, 1)), np.zeros((na, 1))))),
                       axis=0)
        over = np.flatnonzero(still > peak)
        if over.size:
            i = int(over[0])
            raise ValueError(f"motor {i + 1} needs {still[i]:.3g} N·m to hold the centre of the joint ranges "
                             f"against gravity (device file's model), above its peak_torque {peak[i]:.3g} N·m")

    def score(d):
        q, qd, qdd = d.at(t)
        W = model.regressor(q, qd, qdd, threads=1)[:, cols]
        n = np.linalg.norm(W, axis=0)
        Wn = W / np.where(n > 0, n, 1.0)
        ev = np.linalg.eigvalsh(Wn.T @ Wn)          # cond = √(λmax/λmin) of the Gram matrix: 60 × 60, not 720 × 60
        return float(np.sqrt(ev[-1] / max(ev[0], 1e-300))), W

    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):   # small matrices: one thread (IDIM.fit measured 3x)
        return _optimise(project, score, _motor_torque, peak, na, harmonics, seed, iterations, tc, lo_m, hi_m,
                         vmax, why)


def _optimise(project, score, _motor_torque, peak, na, harmonics, seed, iterations, tc, lo_m, hi_m, vmax, why):
    """The (1+1) evolution strategy of :func:`plan_exciting` (one-fifth success rule)."""
    rng = np.random.default_rng(seed)
    L = harmonics
    a0 = rng.normal(size=(na, L)) / np.arange(1, L + 1)
    b0 = rng.normal(size=(na, L)) / np.arange(1, L + 1)
    best = project(a0, b0)
    f_best, W0 = score(best)
    f0, c0 = f_best, float(np.linalg.cond(W0))
    xa, xb = best.a / max(np.abs(best.a).max(), 1e-12), best.b / max(np.abs(best.b).max(), 1e-12)
    sigma = 0.3
    for _ in range(iterations):
        ca = xa + sigma * rng.normal(size=xa.shape)
        cb = xb + sigma * rng.normal(size=xb.shape)
        d = project(ca, cb)
        f, _ = score(d)
        if f < f_best:
            best, f_best, xa, xb = d, f, ca, cb
            sigma *= 1.5
        else:
            sigma *= 1.5 ** -0.25                # one-fifth rule
        sigma = float(np.clip(sigma, 1e-3, 2.0))
    f_best, W = score(best)
    q, qd, _ = best.at(tc)
    y = _motor_torque(best) if peak is not None else None
    limits = {"lower": lo_m.tolist(), "upper": hi_m.tolist(), "max_speed": vmax.tolist(),
              "peak_motor_torque": None if peak is None else peak.tolist()}
    peaks = {"q_min": q.min(axis=0).tolist(), "q_max": q.max(axis=0).tolist(),
             "speed": np.max(np.abs(qd), axis=0).tolist(),
             "motor_torque": None if y is None else np.max(np.abs(y), axis=0).tolist()}
    return ExcitingPlan(best, float(np.linalg.cond(W)), f_best, c0, f0, limits, peaks, iterations + 1, why)
