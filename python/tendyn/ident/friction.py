"""Global friction of one tendon transmission from constant-velocity logs (S0 §III-A, claim C7).

Model (S0 eq. 13, corrected: ERRATA — the motion sign restored — with a load-dependent term)::

    C_m − C_0 = (C_m0 + c_L |C_0|) sgn(q̇_m) + ν q̇_m          [N·m] at the motor, q̇_m [rad/s]

C_0 is the lossless torque of the load at the motor (gravity under the test). S0's law is c_L = 0; the
tension-proportional losses of the device — β along the cable (eq. 11), the reducer's efficiency (eqs. 9–10),
the load part of the bearings (eq. 7) — make the friction grow with the load the cable carries, so a test at
one load puts them into C_m0 and a compensator then over- or under-compensates at every other load. With tests
at two or more loads (``tendyn plan`` plans them) c_L [-] is identified beside C_m0 and ν: with the reducer's
η_i = (2η_d − 1)/η_d (S0 eq. 10) its loss is exactly (1/η_d − 1)|C_0| in both directions of power flow, and a
β loss is the same to first order, so one coefficient holds both (they cannot be told apart at the motor:
:mod:`tendyn.ident.loss_model`). With ``pairs`` the load comes from the logs themselves: the half-sum of the
forward and backward torques at the same position is C_0.

The estimator reads only what a bench records: the motor encoder ``q_motor_<i>`` and the measured
motor torque ``torque_motor_<i>`` (plus, for the gravity model, the other motor encoders). It finds the
constant-speed plateaus itself (:mod:`tendyn.ident.plateaus`) and removes gravity

* ``"pairs"`` (S0's way): a forward and a backward pass over the same path put the arm in the same
  configuration at the same motor position, so C(+v) = g + C_m0 + νv and C(−v) = g − C_m0 − νv; half
  their difference, position bin by position bin, is C_m0 + ν|v| whatever g(q) is (and whatever is even
  in the speed, e.g. centrifugal torques);
* ``"model"``: subtract the device's gravity model (rigid body + lossless statics, C_g = R_m K⁻ᵀ g(q)
  with q from the motor encoders) from every sample, then fit C_m0 sgn(v) + νv to plateau bins of both
  directions;
* ``"both"``: subtract the model, then take the half-differences of the pairs.

Least squares with the statistics of S2 eqs. (4)–(7), corrected: ERRATA — σ̂² = ‖Y − WX̂‖²/(r − b) (the
square), Cov = σ̂²(WᵀW)⁻¹, %σ = 100 σ/|x̂|.

The estimator never reads a truth sidecar; it takes :class:`tendyn.io.Log` objects (or paths, read with
:func:`tendyn.io.read_log`, which reads the log only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.ident.plateaus import Plateau, find_plateaus
from tendyn.protocols import MIN_SPEEDS, PLATEAU
from tendyn.results import Result

from .lsq import IdentificationError, least_squares as _lsq, rel_stderr_pct  # the one least squares and %σ

GRAVITY_MODES = ("pairs", "model", "both")
LOAD_MODES = ("auto", "fit", "none")
STRATEGIES = ("S1", "S2")




@dataclass(eq=False)
class FrictionFit(Result):
    """Identified global friction of one transmission (S0 eq. 13, corrected: ERRATA).

    coulomb_motor C_m0 [N·m], viscous_motor ν [N·m·s/rad], their standard deviations, %σ, cond(W),
    residual standard deviation σ̂ [N·m], the strategy of the logs (``"S1"``, ``"S2"`` or ``None``), the
    motor speeds used [rad/s] (magnitudes, one per direction pair/plateau), the observations (speed [rad/s],
    torque [N·m], weight [samples]) the line was fitted to (weighted least squares: a bin's weight is the
    number of samples it averages), and the strategy's residual-error bound [N·m] when known (ERRATA
    eq. 15; :func:`residual_error_bound`).
    """

    transmission: int
    coulomb_motor: float
    viscous_motor: float
    coulomb_motor_std: float
    viscous_motor_std: float
    residual_std: float
    cond: float
    strategy: str | None
    gravity: str
    speeds_motor: list
    n_points: int
    points: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 4)))
    residual_bound: float | None = None
    load_coefficient: float = 0.0          # c_L [-] (0 when not identified)
    load_coefficient_std: float | None = None
    load_identified: bool = False
    load_range_motor: tuple = (0.0, 0.0)   # smallest and largest |C_0| of the observations [N·m]
    warnings: list = field(default_factory=list)

    @property
    def rel_std_pct(self) -> tuple[float, float]:
        """%σ of (C_m0, ν) (S2 eq. 7)."""
        return (float(rel_stderr_pct(self.coulomb_motor_std, self.coulomb_motor)), float(rel_stderr_pct(self.viscous_motor_std, self.viscous_motor)))

    @property
    def mean_load_motor(self) -> float:
        """Mean |C_0| [N·m] over the observations (weighted as the fit): the load of the test."""
        if self.points.shape[1] < 4 or self.points.shape[0] == 0:
            return 0.0
        return float(np.average(np.abs(self.points[:, 3]), weights=self.points[:, 2]))

    def coulomb_at_load(self, load_motor: float | None = None) -> float:
        """C_m0 + c_L |C_0| [N·m]: the Coulomb part at a load (default: the test's mean load), what S0's
        load-free law (c_L = 0) identifies as C_m0 from a test at that load."""
        load = self.mean_load_motor if load_motor is None else load_motor
        return self.coulomb_motor + self.load_coefficient * abs(load)

    def predict(self, qd_motor, load_motor=0.0) -> np.ndarray:
        """Friction torque C_m − C_0 [N·m] at motor speeds [rad/s] under a lossless load torque C_0 [N·m] at
        the motor (default 0; zero at zero speed)."""
        v = np.asarray(qd_motor, float)
        return (self.coulomb_motor + self.load_coefficient * np.abs(load_motor)) * np.sign(v) + self.viscous_motor * v

    def to_dict(self) -> dict:
        """The FRICTION.json entry of this transmission (see docs/friction-file.md)."""
        rc, rv = (x if math.isfinite(x) else None for x in self.rel_std_pct)   # None when the value is 0
        return {"transmission": self.transmission, "coulomb_motor": self.coulomb_motor,
                "viscous_motor": self.viscous_motor, "coulomb_motor_std": self.coulomb_motor_std,
                "viscous_motor_std": self.viscous_motor_std, "coulomb_motor_rel_std_pct": rc,
                "viscous_motor_rel_std_pct": rv, "residual_std": self.residual_std, "cond": self.cond,
                "strategy": self.strategy, "gravity": self.gravity,
                "speeds_motor": [float(v) for v in self.speeds_motor], "n_points": self.n_points,
                "residual_bound": self.residual_bound,
                "load_coefficient": self.load_coefficient, "load_coefficient_std": self.load_coefficient_std,
                "load_coefficient_rel_std_pct": (None if self.load_coefficient_std is None or self.load_coefficient == 0
                                                 else float(rel_stderr_pct(self.load_coefficient_std, self.load_coefficient))),
                "load_identified": self.load_identified,
                "load_range_motor": [float(x) for x in self.load_range_motor],
                "warnings": list(self.warnings)}

    def table(self) -> str:
        rc, rv = self.rel_std_pct
        bound = "—" if self.residual_bound is None else f"{self.residual_bound:.4g}"
        return "\n".join([
            f"transmission {self.transmission} ({self.strategy or '?'}, gravity: {self.gravity}, "
            f"{len(self.speeds_motor)} speeds, {self.n_points} points, cond {self.cond:.3g})",
            f"{'parameter':<22}{'value':>12}{'σ':>12}{'%σ':>8}",
            f"{'C_m0 [N·m]':<22}{self.coulomb_motor:>12.5g}{self.coulomb_motor_std:>12.3g}{rc:>8.2f}",
            f"{'ν [N·m·s/rad]':<22}{self.viscous_motor:>12.5g}{self.viscous_motor_std:>12.3g}{rv:>8.2f}",
            (f"{'c_L [-]':<22}{self.load_coefficient:>12.5g}{self.load_coefficient_std:>12.3g}"
             f"{float(rel_stderr_pct(self.load_coefficient_std, self.load_coefficient)):>8.2f}" if self.load_identified else
             f"c_L [-] not identified (loads {self.load_range_motor[0]:.3g}…{self.load_range_motor[1]:.3g} N·m)"),
            f"residual σ̂ {self.residual_std:.3g} N·m; residual-error bound (ERRATA eq. 15) {bound} N·m",
        ] + [f"warning: {w}" for w in self.warnings])

    reading = ('Friction torque at the motor of each speed bin of the constant-velocity test (dots) and the fitted '
               'law (line): the jump at zero speed is the Coulomb friction, the slope the viscous one.')

    def _draw(self, ax) -> None:
        """Observations and the fitted law C_m0 sgn(v) + νv."""
        v, c = self.points[:, 0], self.points[:, 1]
        load = self.points[:, 3] if self.points.shape[1] > 3 else np.zeros_like(v)
        ax.plot(v, c - self.load_coefficient * load * np.sign(v), ".", ms=3, alpha=0.5,
                label="plateau bins" + (" − c_L |C_0|" if self.load_identified else ""))
        vv = np.linspace(min(0.0, v.min()), v.max(), 200)
        vv = vv[vv != 0]
        ax.plot(vv, self.predict(vv), "-", label=f"fit C_m0={self.coulomb_motor:.4g} N·m, "
                f"ν={self.viscous_motor:.3g} N·m·s/rad" + (f", c_L={self.load_coefficient:.3g}"
                                                          if self.load_identified else ""))
        ax.set_xlabel(f"motor {self.transmission} speed [rad/s]")
        ax.set_ylabel("friction torque at the motor [N·m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)


def least_squares(W, y, weights=None):
    """x̂, Cov, σ̂, cond(W) of the weighted bins (rows scaled by √w): :func:`tendyn.ident.lsq.least_squares`,
    the one least squares of identification (S2 eqs. 4–6, corrected: ERRATA — the square)."""
    x, _, s2, cov = _lsq(W, y, weights)
    sw = np.sqrt(np.asarray(weights, float)) if weights is not None else np.ones(len(y))
    return x, cov, math.sqrt(s2), float(np.linalg.cond(np.asarray(W, float) * sw[:, None]))


# ---- reading logs -----------------------------------------------------------------------------------

def _as_log(log):
    from tendyn.io import Log, read_log

    return log if isinstance(log, Log) else read_log(log)


def log_transmission(log) -> int:
    """The transmission a constant-velocity log moves: ``options.transmission`` when the log says so,
    else the motor whose encoder travels fastest (S1 and S2 move the other motors less or not at all)."""
    opt = log.meta.get("options", {}) or {}
    t = opt.get("transmission")
    if isinstance(t, int) and not isinstance(t, bool):
        return t
    q = log.stack("q_motor_")
    speed = np.abs(np.diff(q, axis=0)).sum(axis=0)
    return int(np.argmax(speed)) + 1


def log_strategy(log) -> str | None:
    """"S1"/"S2" from ``options.strategy`` or the experiment name, else None."""
    opt = log.meta.get("options", {}) or {}
    s = opt.get("strategy")
    if s in STRATEGIES:
        return s
    for s in STRATEGIES:
        if str(log.meta.get("experiment", "")).endswith(s):
            return s
    return None


def gravity_motor_torque(device, q_motor) -> np.ndarray:
    """Motor torques [N·m] that hold the device against gravity, lossless (S0 eq. 5, corrected: ERRATA):
    q = K⁻¹ R_m q_m from the encoders (S0 eqs. 1–2), g(q) from the rigid body, C_g = R_m K⁻ᵀ g.

    q_motor : (n_samples, n) motor positions [rad]. Returns (n_samples, n)."""
    import pinocchio as pin

    from tendyn.device.rigid_body import pinocchio_model
    from tendyn.transmission import Transmission

    tr = Transmission.from_device(device)
    mats = tr.matrices()
    J_from_M = mats["joint_from_motor_position"]
    M_from_tau = mats["motor_from_joint_torque"]
    pm = pinocchio_model(device)
    pd = pm.createData()
    q = np.asarray(q_motor, float) @ J_from_M.T
    out = np.empty_like(q)
    for k in range(q.shape[0]):
        out[k] = M_from_tau @ pin.computeGeneralizedGravity(pm, pd, q[k])
    return out


# ---- the estimator --------------------------------------------------------------------------------

@dataclass
class _Stroke:
    plateau: Plateau
    q: np.ndarray        # motor position of the transmission [rad]
    c: np.ndarray        # torque (gravity model removed when asked) [N·m]
    log_index: int
    load: np.ndarray     # the lossless load torque at the motor where known (gravity model), else the torque [N·m]


class TransmissionFriction:
    """Estimator of C_m = C_m0 sgn(q̇_m) + ν q̇_m for one transmission (S0 eq. 13, corrected: ERRATA).

    Parameters (hyper-parameters, stored as given)
    ----------
    transmission : int
        1-based transmission number (its motor's columns are read).
    gravity : {"pairs", "model", "both"}
        How gravity is removed (module docstring). "model" and "both" need ``device``.
    device : tendyn.device.Device or None
        For the gravity model only (its rigid body and routing; never its friction values).
    min_speeds : int
        Fewest distinct speeds per direction accepted (:data:`tendyn.protocols.MIN_SPEEDS`, the rule the planner
        follows).
    bins : int
        Position bins per plateau (pair); each bin is one observation.
    window_s, tol, min_speed, min_duration_s, trim_s :
        Plateau detection, see :func:`tendyn.ident.plateaus.find_plateaus`.
    speed_match : float
        Relative speed difference allowed between the two passes of a pair [-] (the pair's mean speed is the
        observation's; a position loop holds a light distal link's high speeds within a few per cent only).
    load : {"auto", "fit", "none"}
        The load-dependent term c_L |C_0| (module docstring): "fit" always; "none" never (S0's law);
        "auto" (default) keeps it when the data determine it — |ĉ_L| > ``load_significance`` σ — and when it is
        not negative (a friction that falls with the load is no loss law); otherwise c_L = 0 and the fit says why.
    load_significance : float
        The t-value [-] above which "auto" keeps c_L.
    bound_tau0, bound_nu : (n, n) arrays or None
        Per-branch Coulomb [N] and viscous [N·s/m] values of the device's transmissions (nominal, or
        decomposed from identified global values: :func:`tendyn.ident.decompose`); with ``device`` they give
        ``residual_bound_`` (ERRATA eq. 15, :func:`residual_error_bound`) for the logs' strategy.

    Learned attributes
    ------------------
    params_ : (2,) [C_m0 N·m, ν N·m·s/rad], or (3,) with c_L [-] when the load term is kept;
    stderr_ : their σ;  rel_stderr_ : %σ;  load_coefficient_ : c_L [-] (0 when not kept);  load_identified_ ;
    cond_ : cond(W);  coulomb_motor_, viscous_motor_ ;  residual_std_ : σ̂ [N·m];  warnings_ : list of text;
    speeds_ : distinct speed magnitudes used [rad/s];  plateaus_ : per log, the plateaus found;
    strategy_ : "S1", "S2" or None (from the logs' meta);  residual_bound_ : [N·m] or None;
    result_ : :class:`FrictionFit`.
    """

    def __init__(self, transmission: int, gravity: str = "pairs", device=None, min_speeds: int = MIN_SPEEDS,
                 bins: int = 16, window_s: float = PLATEAU["window_s"], tol: float = PLATEAU["tol"],
                 min_speed: float = PLATEAU["min_speed"], min_duration_s: float = PLATEAU["min_duration_s"],
                 trim_s: float = PLATEAU["trim_s"], speed_match: float = 0.1,
                 bound_tau0=None, bound_nu=None, load: str = "auto", load_significance: float = 3.0):
        self.transmission = transmission
        self.gravity = gravity
        self.device = device
        self.min_speeds = min_speeds
        self.bins = bins
        self.window_s = window_s
        self.tol = tol
        self.min_speed = min_speed
        self.min_duration_s = min_duration_s
        self.trim_s = trim_s
        self.speed_match = speed_match
        self.bound_tau0 = bound_tau0
        self.bound_nu = bound_nu
        self.load = load
        self.load_significance = load_significance

    def get_params(self, deep: bool = True) -> dict:
        return {k: getattr(self, k) for k in ("transmission", "gravity", "device", "min_speeds", "bins",
                                              "window_s", "tol", "min_speed", "min_duration_s", "trim_s",
                                              "speed_match", "bound_tau0", "bound_nu", "load",
                                              "load_significance")}

    # ---- fit ----
    def fit(self, logs) -> "TransmissionFriction":
        """Fit to one log or a list of logs (:class:`tendyn.io.Log` or paths). Returns self."""
        if self.gravity not in GRAVITY_MODES:
            raise ValueError(f"gravity must be one of {GRAVITY_MODES} (got {self.gravity!r})")
        if self.gravity != "pairs" and self.device is None:
            raise ValueError(f"gravity={self.gravity!r} needs the device (its gravity model)")
        if self.load not in LOAD_MODES:
            raise ValueError(f"load must be one of {LOAD_MODES} (got {self.load!r})")
        if not isinstance(logs, (list, tuple)):
            logs = [logs]
        logs = [_as_log(lg) for lg in logs]
        i = self.transmission
        strokes: list[_Stroke] = []
        self.plateaus_ = []
        strategies = set()
        for n, log in enumerate(logs):
            qname, cname = f"q_motor_{i}", f"torque_motor_{i}"
            for name in (qname, cname):
                if name not in log:
                    raise IdentificationError(f"log {n + 1}: no column {name} (transmission {i})")
            t, q, c = log.time, log[qname], log[cname]
            load = c
            if self.gravity != "pairs":
                load = gravity_motor_torque(self.device, log.stack("q_motor_"))[:, i - 1]
                c = c - load
            ps = find_plateaus(t, q, window_s=self.window_s, tol=self.tol, min_speed=self.min_speed,
                               min_duration_s=self.min_duration_s, trim_s=self.trim_s)
            self.plateaus_.append(ps)
            strokes += [_Stroke(p, q[p.slice], c[p.slice], n, load[p.slice]) for p in ps]
            strategies.add(log_strategy(log))
        if not strokes:
            raise IdentificationError(f"transmission {i}: no constant-speed plateau in the logs")
        if self.gravity == "model":
            points = self._bins_model(strokes)
        else:
            points = self._bins_pairs(strokes)
        speeds = _distinct(np.abs(points[:, 0]), self.speed_match)
        need = self.min_speeds
        if self.gravity == "model":
            pos = _distinct(points[points[:, 0] > 0, 0], self.speed_match)
            neg = _distinct(-points[points[:, 0] < 0, 0], self.speed_match)
            if min(len(pos), len(neg)) < need:
                raise IdentificationError(f"transmission {i}: {len(pos)} positive and {len(neg)} negative "
                                          f"speeds found, need at least {need} per direction")
        elif len(speeds) < need:
            seen = sorted({round(abs(s.plateau.speed), 3) for s in strokes})
            raise IdentificationError(f"transmission {i}: forward/backward pairs at {len(speeds)} speeds, need at "
                                      f"least {need} per direction (pairs at {', '.join(f'{v:.3g}' for v in speeds)}"
                                      f" rad/s; plateaus at {', '.join(f'{v:g}' for v in seen)} rad/s): plan the "
                                      "test with tendyn plan constant-velocity (its strokes hold each speed long "
                                      "enough) or lower --min-speeds")
        x, cov, s, cond, kept, self.warnings_ = self._fit_law(points, i)
        x, cov = self._nonnegative(points, x, cov, kept, i)
        self.params_ = x
        self.stderr_ = np.sqrt(np.diag(cov))
        self.rel_stderr_ = rel_stderr_pct(self.stderr_, x)
        self.cond_ = cond
        self.coulomb_motor_, self.viscous_motor_ = float(x[0]), float(x[1])
        self.load_identified_ = kept
        self.load_coefficient_ = float(x[2]) if kept else 0.0
        self.residual_std_ = s
        self.speeds_ = speeds
        self.points_ = points
        strategies.discard(None)
        self.strategy_ = strategies.pop() if len(strategies) == 1 else None
        loads = np.abs(points[:, 3])
        self.result_ = FrictionFit(i, float(x[0]), float(x[1]), float(self.stderr_[0]), float(self.stderr_[1]),
                                   s, cond, self.strategy_, self.gravity, [float(u) for u in speeds],
                                   int(points.shape[0]), points, load_coefficient=self.load_coefficient_,
                                   load_coefficient_std=float(self.stderr_[2]) if kept else None,
                                   load_identified=kept, load_range_motor=(float(loads.min()), float(loads.max())),
                                   warnings=list(self.warnings_))
        self.residual_bound_ = None
        if self.device is not None and self.bound_tau0 is not None and self.strategy_ in STRATEGIES:
            arr = self.device.routing_arrays()
            self.residual_bound_ = residual_error_bound(arr["K"], arr["motor_radius"], i - 1, self.strategy_,
                                                        self.bound_tau0, self.bound_nu, max(speeds))
        self.result_.residual_bound = self.residual_bound_
        return self

    def predict(self, qd_motor, load_motor=0.0) -> np.ndarray:
        """Friction torque at the motor [N·m] at motor speeds ``qd_motor`` [rad/s] (and loads [N·m])."""
        return self.result_.predict(qd_motor, load_motor)

    def score(self, qd_motor, torque, load_motor=0.0) -> float:
        """‖C − Ĉ‖ / ‖C‖ [-]: relative error of :meth:`predict` against friction torques ``torque`` [N·m]
        measured at ``qd_motor`` (e.g. the plateau bins ``points_[:, :2]`` of another set of logs)."""
        c = np.asarray(torque, float)
        return float(np.linalg.norm(c - self.predict(qd_motor, load_motor)) / max(np.linalg.norm(c), 1e-300))

    def _fit_law(self, points, i):
        """Weighted least squares of the law (module docstring) on the bins: (x, Cov, σ̂, cond, load kept,
        warnings). Columns sgn v, v and, for the load term, |C_0| sgn v."""
        v, y, w, load = points[:, 0], points[:, 1], points[:, 2], np.abs(points[:, 3])
        W = np.column_stack([np.sign(v), v])
        weights = w / w.mean()
        warnings = []
        if self.load != "none":
            W3 = np.column_stack([W, load * np.sign(v)])
            if np.linalg.matrix_rank(W3 * np.sqrt(weights)[:, None], tol=1e-9 * np.abs(W3).max()) == 3:
                x, cov, s, cond = least_squares(W3, y, weights)
                sc = math.sqrt(cov[2, 2])
                if self.load == "fit":
                    return x, cov, s, cond, True, warnings
                if x[2] >= 0 and abs(x[2]) > self.load_significance * sc:
                    return x, cov, s, cond, True, warnings
                why = (f"c_L = {x[2]:.3g} ± {sc:.2g} is negative: no loss law falls with the load (the tests' "
                       "loads or speeds may be inconsistent)" if x[2] < 0 and abs(x[2]) > self.load_significance * sc
                       else f"c_L = {x[2]:.3g} ± {sc:.2g} is not significant (loads {load.min():.3g}…"
                       f"{load.max():.3g} N·m)")
            else:
                why = f"one load only ({load.min():.3g}…{load.max():.3g} N·m)"
            warnings.append(f"transmission {i}: load term not identified, c_L = 0: {why}; plan tests at two or "
                            "more loads (tendyn plan constant-velocity --loads 2) to identify it")
        x, cov, s, cond = least_squares(W, y, weights)
        return x, cov, s, cond, False, warnings

    def _nonnegative(self, points, x, cov, kept, i):
        """A loss law has no negative term: a coefficient that comes out negative (the S2 residual of held distal
        cables can exceed a small ν, ERRATA eq. 15) is fixed at 0 and the others refitted; the fit says so.
        Returns (x, Cov) with the fixed entries 0 (σ 0)."""
        names = ["C_m0", "ν", "c_L"][:x.size]
        fixed = [k for k in range(x.size) if x[k] < 0]
        if not fixed:
            return x, cov
        v, y, w, load = points[:, 0], points[:, 1], points[:, 2], np.abs(points[:, 3])
        cols = [np.sign(v), v, load * np.sign(v)][:x.size]
        while True:
            free = [k for k in range(x.size) if k not in fixed]
            xf = np.zeros(x.size)
            covf = np.zeros((x.size, x.size))
            if free:
                xs, cs, _, _ = least_squares(np.column_stack([cols[k] for k in free]), y, w / w.mean())
                xf[free] = xs
                covf[np.ix_(free, free)] = cs
            more = [k for k in free if xf[k] < 0]
            if not more:
                break
            fixed += more
        self.warnings_.append(f"transmission {i}: {', '.join(f'{names[k]} = {x[k]:.3g}' for k in fixed)} came out "
                              "negative: fixed at 0 and the rest refitted (a friction term cannot feed energy; the "
                              "S2 residual of held distal cables, ERRATA eq. 15, or a torque offset can cause it)")
        return xf, covf

    def _bins_model(self, strokes):
        rows = []
        for s in strokes:
            edges = np.linspace(s.q.min(), s.q.max(), self.bins + 1)
            idx = np.clip(np.searchsorted(edges, s.q, side="right") - 1, 0, self.bins - 1)
            for b in range(self.bins):
                sel = idx == b
                if sel.sum() >= 3:
                    rows.append((s.plateau.speed, float(s.c[sel].mean()), float(sel.sum()),
                                 abs(float(s.load[sel].mean()))))
        return np.array(rows, float).reshape(-1, 4)

    def _bins_pairs(self, strokes):
        """Half-differences of forward and backward passes, bin by bin over their common path; the load of a
        bin is its half-sum (pairs) or the gravity model's torque (both). A forward pass pairs with the
        backward pass of matching speed that overlaps it, the nearest in time (tests at several loads run the
        same speeds at several poses)."""
        rows = []
        neg = [s for s in strokes if s.plateau.speed < 0]
        for s in (s for s in strokes if s.plateau.speed > 0):
            v = s.plateau.speed
            best, gap = None, math.inf
            for o in neg:
                if o.log_index != s.log_index or abs(-o.plateau.speed - v) > self.speed_match * v:
                    continue
                lo, hi = max(s.q.min(), o.q.min()), min(s.q.max(), o.q.max())
                if hi - lo < 0.5 * min(np.ptp(s.q), np.ptp(o.q)):
                    continue
                d = abs(o.plateau.start - s.plateau.start)
                if d < gap:
                    best, gap = o, d
            if best is None:
                continue
            lo, hi = max(s.q.min(), best.q.min()), min(s.q.max(), best.q.max())
            edges = np.linspace(lo, hi, self.bins + 1)
            vbar = 0.5 * (v - best.plateau.speed)
            for b in range(self.bins):
                a_sel = (s.q >= edges[b]) & (s.q < edges[b + 1])
                b_sel = (best.q >= edges[b]) & (best.q < edges[b + 1])
                na, nb = a_sel.sum(), b_sel.sum()
                if na >= 3 and nb >= 3:
                    # weight ∝ 1 / variance of the half-difference of two means: 1 / (1/na + 1/nb)
                    rows.append((vbar, 0.5 * float(s.c[a_sel].mean() - best.c[b_sel].mean()),
                                 1.0 / (1.0 / na + 1.0 / nb),
                                 abs(0.5 * float(s.load[a_sel].mean() + best.load[b_sel].mean()))))
        return np.array(rows, float).reshape(-1, 4)


def _distinct(values, rel: float) -> list[float]:
    """Cluster speed magnitudes within ``rel`` of each other; their means, sorted."""
    vals = np.sort(np.asarray(values, float))
    out: list[list[float]] = []
    for x in vals:
        if out and x - out[-1][-1] <= rel * x:
            out[-1].append(x)
        else:
            out.append([x])
    return [float(np.mean(c)) for c in out]


# ---- residual-error bound (ERRATA eq. 15) -------------------------------------------------------------

def isolated_move_joint_speeds(K, motor_radius, j: int, strategy: str, qd_motor: float = 1.0) -> np.ndarray:
    """Joint speeds [rad/s] while transmission j (0-based) moves at motor speed ``qd_motor``.

    S2: only joint j moves, q̇_j = r_m^j q̇_m^j / r_j^j. S1 (the other motors held): S0 eq. 14, corrected:
    ERRATA — q̇_i = 0 for i < j, q̇_j = r_m^j q̇_m^j / r_j^j, q̇_i = −(1/r_i^i) Σ_{k=j}^{i−1} r_k^i q̇_k."""
    K = np.asarray(K, float)
    n = K.shape[0]
    qd = np.zeros(n)
    serial = np.all(np.triu(K, 1) == 0)
    if strategy == "S1" and not serial:  # general routing (issue 19): q̇ = K⁻¹ R_m e_j q̇_m
        rhs = np.zeros(n)
        rhs[j] = motor_radius[j] * qd_motor
        return np.linalg.solve(K, rhs)
    if K[j, j] == 0.0:
        raise ValueError(f"transmission {j + 1} does not wrap its own joint (zero driven radius): an S2 move of "
                         "that joint alone is not a move of its motor alone")
    qd[j] = motor_radius[j] * qd_motor / K[j, j]
    if strategy == "S1":
        for i in range(j + 1, n):
            qd[i] = -sum(K[i, k] * qd[k] for k in range(j, i)) / K[i, i]
    return qd


def branch_speeds(K, qd) -> np.ndarray:
    """Ṡ[i, b] = Σ_{l ≥ b} K[i, l] q̇_l [m/s] (branch b of transmission i, relative to its link)."""
    K = np.asarray(K, float)
    n = K.shape[0]
    S = np.zeros_like(K)
    for i in range(n):
        last = max([i] + [j for j in range(i + 1, K.shape[1]) if K[i, j] != 0.0])  # > i: a differential
        for b in range(last + 1):
            S[i, b] = float(np.dot(K[i, b:last + 1], qd[b:last + 1]))
    return S


def residual_error_bound(K, motor_radius, j: int, strategy: str, tau0, nu=None, speed: float = 0.0) -> float:
    """Bound [N·m] on the error of motor j's measured friction torque (0-based j) — ERRATA eq. 15.

    S2 (S0 eq. 15, corrected: ERRATA): the residual static tension of each transmission k > j that
    crosses joint j reaches motor j through joint j:
        |C_err^j| ≤ (r_m^j / r_j^j) Σ_{k>j} |r_j^k| Σ_{l=j+1}^{k} τ_{0,l}^k      (0-based branches l > j:
    the branches beyond joint j, still under S2).
    S1: the branches of the distal transmissions beyond joint j slide (S0 eq. 14); the power they
    dissipate is supplied by motor j: C_err^j = Σ_{k>j} Σ_l (τ_{0,l}^k |k'_l^k| + ν_l^k (k'_l^k)² |q̇_m|), with
    k'_l^k = Ṡ_l^k / q̇_m^j; inertial (Coriolis/centrifugal) torques are even in the speed and cancel in the
    forward/backward half-difference, so they are not added.

    tau0, nu : (n, n) per-branch Coulomb [N] and viscous [N·s/m] values (identified or nominal);
    speed : the motor speed magnitude [rad/s] at which the S1 viscous part is evaluated.
    """
    K = np.asarray(K, float)
    r_m = np.asarray(motor_radius, float)
    tau0 = np.asarray(tau0, float)
    n = K.shape[0]
    if strategy == "S2":
        return float(r_m[j] / K[j, j] * sum(abs(K[k, j]) * tau0[k, j + 1:k + 1].sum() for k in range(j + 1, n)))
    if strategy != "S1":
        raise ValueError(f"strategy must be 'S1' or 'S2' (got {strategy!r})")
    nu = np.zeros_like(tau0) if nu is None else np.asarray(nu, float)
    kp = branch_speeds(K, isolated_move_joint_speeds(K, r_m, j, "S1", 1.0))
    err = 0.0
    for k in range(j + 1, n):
        for b in range(k + 1):
            err += tau0[k, b] * abs(kp[k, b]) + nu[k, b] * kp[k, b] ** 2 * abs(speed)
    return float(err)
