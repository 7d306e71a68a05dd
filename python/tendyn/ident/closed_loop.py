"""Closed-loop identification as its authors do it: IDIM-IV and DIDIM (Janot, Gautier et al.).

Both simulate the *identified* inverse dynamic model (IDM) in closed loop, driven by the logged reference through
the controller that ran on the bench (the twin's PID written in the log's meta, a :class:`LoopController` the user
gives, or a C(z) per joint):

* **IDIM-IV** (Janot, Gautier, Jubien, Vandanjon 2014, "Comparison between the CLOE method and the DIDIM method
  for robots identification", and Janot et al. 2014 IEEE TCST "A generic instrumental variable approach for
  industrial robot identification"): the instruments Z are the regressor of the *simulated* positions, treated
  exactly as the measured ones (same Butterworth, differences, parallel filter, decimation, rows); the estimate is
  X = (Zᵀ W)⁻¹ Zᵀ Y, the simulation is redone with it, until the estimate stops moving. Noise on the encoders is
  in W but not in Z, so the bias of least squares on noisy closed-loop data goes.
* **DIDIM** (Gautier, Janot, Vandanjon 2013 IEEE TCST "A new closed-loop output error method for parameter
  identification of robot dynamics"): Gauss–Newton on the error between the measured and the simulated outputs
  (the controller's torques, or the positions), started from IDIM-LS. Jacobian ``"idm"``: the regressor on the
  simulated states (the simulated torque *is* W(q_s, q̇_s, q̈_s) X, and Gautier's choice neglects ∂q_s/∂X: one
  simulation per iteration); ``"fd"``: central… forward finite differences of the simulated output, the b
  perturbed simulations run together in one batched loop (the true Gauss–Newton; the only choice for positions).

The simulation: state (q, q̇) of the active joints, q̈ = A(q)⁻¹ (τ − W(q, q̇, 0) X) with A's columns
W(q, 0, e_i) X − W(q, 0, 0) X over the inertial columns (:meth:`IdentModel.mass_matrix`), the controller updated
at every log sample (its rate), semi-implicit Euler at the log's sample time (compiled:
``include/tendyn/closed_loop.hpp``, one tree pass per step for A and b; the regressor-built Python loop for
devices with ``[[terms]]``); ideal sensors (the model of the
device, not of its noise). An estimator here never reads a twin's truth: only the log (positions, torques,
reference, controller).
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from .lsq import IdentificationError, instrumental_variables, least_squares

__all__ = ["LoopController", "ClosedLoopError", "controller_of", "simulate_loop", "closed_loop_data"]


class ClosedLoopError(IdentificationError):
    """The log cannot be identified in closed loop (no reference, no controller): the message says why."""


@dataclasses.dataclass(frozen=True)
class LoopController:
    """A decentralised discrete PID per active joint (joint space) or per motor (motor space), as the twin runs it
    (``include/tendyn/sim.hpp``, ``control``): e = r − q, I += e T, u = kp e + kd (v_r − v̂) + ki I, with v̂ the
    first-order filtered difference of the position (cut-off ``velocity_cutoff_hz``, 0 = none).

    kp [N·m/rad or N/m], kd [N·m·s/rad], ki [N·m/(rad·s)] : (n,) gains; motor space: at the motor, the joint
        torque is Gᵀ u.
    space : "joint" or "motor" (the references are ``q_ref_<j>``/``qd_ref_<j>`` or ``q_motor_ref_<i>``…).
    velocity_feedforward : True: kd (v_r − v̂) (the twin); False: −kd v̂ (a cascade P–P loop such as the EMPS's,
        u = kv (kp (r − q) − v̂) gives kp_here = kv kp, kd = kv).
    gain : (n,) output scale [N·m per controller unit] (EMPS: the drive gain, N/V); 1 by default.
    """

    kp: tuple
    kd: tuple
    ki: tuple
    space: str = "joint"
    velocity_cutoff_hz: float = 0.0
    velocity_feedforward: bool = True
    gain: tuple | None = None
    label: str = ""

    def to_dict(self) -> dict:
        return {"kind": "pid", "kp": list(map(float, self.kp)), "kd": list(map(float, self.kd)),
                "ki": list(map(float, self.ki)), "space": self.space,
                "velocity_cutoff_hz": float(self.velocity_cutoff_hz),
                "velocity_feedforward": bool(self.velocity_feedforward),
                "gain": None if self.gain is None else list(map(float, self.gain)), "label": self.label}

    @classmethod
    def from_dict(cls, d: dict) -> "LoopController":
        """The controller of :meth:`to_dict` (the twin writes it into ``meta.options["controller"]``)."""
        if d.get("kind") != "pid":
            raise ClosedLoopError(f"controller of kind {d.get('kind')!r}: only a PID per joint or motor is "
                                  "simulated for IDIM-IV / DIDIM")
        return cls(tuple(d["kp"]), tuple(d["kd"]), tuple(d.get("ki") or [0.0] * len(d["kp"])),
                   str(d.get("space", "joint")), float(d.get("velocity_cutoff_hz", 0.0)),
                   bool(d.get("velocity_feedforward", True)),
                   None if d.get("gain") is None else tuple(d["gain"]), str(d.get("label", "")))


def controller_of(log, given=None) -> LoopController:
    """The controller that closed the loop of ``log``: ``given`` (a LoopController or its dict) first, else the
    log's ``meta.options["controller"]``; :class:`ClosedLoopError` (one line) when neither is known."""
    if given is not None:
        return given if isinstance(given, LoopController) else LoopController.from_dict(dict(given))
    opts = (getattr(log, "meta", None) or {}).get("options") or {}
    d = opts.get("controller") if isinstance(opts, dict) else None
    if not d:
        raise ClosedLoopError("no controller is known for this log (its meta has no options.controller): IDIM-IV "
                              "and DIDIM simulate the loop, give one (--controller FILE.json) or use --method ols")
    return LoopController.from_dict(d)


def _references(model, log, space):
    """Reference positions and velocities (n, n_ref) of the log, joint or motor space."""
    prefix, vprefix = ("q_ref_", "qd_ref_") if space == "joint" else ("q_motor_ref_", "qd_motor_ref_")
    n = model.n_active if space == "joint" else model.n_motors
    names = [f"{prefix}{i + 1}" for i in range(n)]
    if not all(c in log for c in names):
        raise ClosedLoopError(f"the log has no reference {prefix}1…{prefix}{n}: IDIM-IV and DIDIM drive the "
                              "simulation with the logged reference; use --method ols")
    r = np.column_stack([np.asarray(log[c], float) for c in names])
    vnames = [f"{vprefix}{i + 1}" for i in range(n)]
    if all(c in log for c in vnames):
        v = np.column_stack([np.asarray(log[c], float) for c in vnames])
    else:
        v = np.gradient(r, np.asarray(log.time, float), axis=0)
    return r, v


def simulate_loop(model, X, controller: LoopController, ref_q, ref_qd, q0, dt: float, substeps: int = 1,
                  engine: str = "auto"):
    """Simulate the IDM of standard-order parameter vectors ``X`` in closed loop.

    ``engine``: ``"core"`` the compiled loop (``tendyn._core.closed_loop_simulate``, include/tendyn/closed_loop.hpp:
    mass matrix and bias of the links' parameters in one tree pass per step, ≈ 3 µs a step for six joints);
    ``"python"`` the loop below that builds A and b from regressor calls (≈ 150 µs a step: the reference the
    compiled loop is tested against, and the route of a device with ``[[terms]]``); ``"auto"`` the first that
    applies. Both integrate the same model with the same controller.

    Parameters
    ----------
    model : IdentModel
    X : (n_std,) or (p, n_std) parameter vectors over :attr:`IdentModel.standard_names` (p runs at once, the
        finite-difference Jacobian)
    controller : LoopController
    ref_q, ref_qd : (n, n_ref) reference positions [rad or m] and velocities, one per step
    q0 : (n_active,) initial joint positions (at rest)
    dt : step = controller period [s]
    substeps : integration steps per controller period (the torque held between controller updates)

    Returns
    -------
    q, qd, qdd, tau : (p, n, n_active) joint positions, velocities, accelerations and the controller's joint
        torques [N·m] (p dropped when X was 1-D)
    """
    if engine not in ("auto", "core", "python"):
        raise ValueError(f"engine must be 'auto', 'core' or 'python' (got {engine!r})")
    if engine == "core" or (engine == "auto" and not len(model.terms)):
        return _simulate_loop_core(model, X, controller, ref_q, ref_qd, q0, dt, substeps)
    X = np.asarray(X, float)
    single = X.ndim == 1
    X = np.atleast_2d(X)
    p, na = X.shape[0], model.n_active
    inert = model.inertial_columns()
    Xi = np.where(inert, X, 0.0)
    n = ref_q.shape[0]
    G = model.G
    motor = controller.space == "motor"
    nr = ref_q.shape[1]
    kp, kd, ki = (np.asarray(v, float) for v in (controller.kp, controller.kd, controller.ki))
    gain = np.ones(nr) if controller.gain is None else np.asarray(controller.gain, float)
    if kp.size != nr:
        raise ClosedLoopError(f"the controller has {kp.size} gains, the reference {nr} columns")
    fc = float(controller.velocity_cutoff_hz)
    alpha = 1.0 - np.exp(-2 * np.pi * fc * dt) if fc > 0 else 1.0
    vff = 1.0 if controller.velocity_feedforward else 0.0
    off = model.joint_offsets
    q = np.tile(np.asarray(q0, float), (p, 1))
    qd = np.zeros((p, na))
    meas = lambda qq: (qq - off) @ G.T if motor else qq
    y_prev = meas(q)
    v_est = np.zeros((p, nr))
    integ = np.zeros((p, nr))
    out_q, out_qd, out_qdd, out_tau = (np.empty((p, n, na)) for _ in range(4))
    eye = np.eye(na)
    # one regressor call per step: for each run, na rows q̈ = e_i (q̇ = 0), one at (q, 0, 0), one at (q, q̇, 0)
    m = na + 2
    qdd_pat = np.vstack([eye, np.zeros((2, na))])
    QDD = np.tile(qdd_pat, (p, 1))
    substeps = max(int(substeps), 1)
    h = dt / substeps
    known = model.terms.has_known if len(model.terms) else False
    for k in range(n):
        y = meas(q)
        v_est += alpha * ((y - y_prev) / dt - v_est)
        y_prev = y
        e = ref_q[k] - y
        integ += e * dt
        u = gain * (kp * e + kd * (vff * ref_qd[k] - v_est) + ki * integ)
        tau = u @ G if motor else u
        out_q[:, k], out_qd[:, k], out_tau[:, k] = q, qd, tau
        for s in range(substeps):
            Q = np.repeat(q, m, axis=0)
            QD = np.zeros_like(Q)
            QD[m - 1::m] = qd
            W = model.regressor(Q, QD, QDD, threads=1)          # (na * p m, cols), joint-major
            W = W.reshape(na, p, m, -1)
            tM = np.einsum("jrmc,rc->rjm", W[:, :, :na + 1], Xi)   # inertial part: A columns + gravity-free base
            A = tM[:, :, :na] - tM[:, :, na:na + 1]
            b = np.einsum("jrc,rc->rj", W[:, :, na + 1], X)
            if known:
                b = b + model.known_torque(q)
            qdd = (tau - b) / A[:, :, 0] if na == 1 else np.linalg.solve(A, (tau - b)[..., None])[..., 0]
            if s == 0:
                out_qdd[:, k] = qdd
            q = q + (qd + 0.5 * qdd * h) * h          # exact for the acceleration held over the step
            qd = qd + qdd * h
    if single:
        return out_q[0], out_qd[0], out_qdd[0], out_tau[0]
    return out_q, out_qd, out_qdd, out_tau


def _simulate_loop_core(model, X, controller, ref_q, ref_qd, q0, dt, substeps):
    """:func:`simulate_loop` by the compiled loop: X (standard order) scattered to the regressor's columns."""
    import os

    from tendyn import _core

    if len(model.terms):
        raise ClosedLoopError("the compiled closed-loop simulation has no [[terms]] columns: use engine='python'")
    X = np.asarray(X, float)
    single = X.ndim == 1
    X = np.atleast_2d(X)
    p, na, nr = X.shape[0], model.n_active, ref_q.shape[1]
    Xc = np.zeros((p, _core.regressor_columns(model.rigid_body, na, model.n_motors)))
    Xc[:, model.standard_columns] = X
    kp, kd, ki = (np.asarray(v, float) for v in (controller.kp, controller.kd, controller.ki))
    if kp.size != nr:
        raise ClosedLoopError(f"the controller has {kp.size} gains, the reference {nr} columns")
    gain = np.ones(nr) if controller.gain is None else np.asarray(controller.gain, float)
    f = lambda a: np.ascontiguousarray(a, float)
    threads = min(p, len(os.sched_getaffinity(0)))
    out = _core.closed_loop_simulate(model.rigid_body, f(model.L), f(model.c), f(model.G), Xc, kp, kd, ki, gain,
                                     controller.space == "motor", float(controller.velocity_cutoff_hz),
                                     bool(controller.velocity_feedforward), f(ref_q), f(ref_qd), f(q0),
                                     f(model.joint_offsets), float(dt), max(int(substeps), 1), threads)
    n = ref_q.shape[0]
    out = [o.reshape(p, n, na) for o in out]
    return tuple(o[0] for o in out) if single else tuple(out)


@dataclasses.dataclass
class LoopLog:
    """One log ready for closed-loop identification: measured (time, q, τ, q̇ or None), reference, controller."""

    time: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None
    ref_q: np.ndarray
    ref_qd: np.ndarray
    controller: LoopController
    rate_hz: float


def closed_loop_data(model, log, controller=None) -> LoopLog:
    """Signals of one log for IDIM-IV / DIDIM; refuses (ClosedLoopError, one line) a log without a reference or
    a known controller."""
    from tendyn.io import read_log

    if not hasattr(log, "meta"):
        log = read_log(log)
    try:
        ctrl = controller_of(log, controller)
    except ClosedLoopError as exc:
        if not log.column_names("q_ref_") and not log.column_names("q_motor_ref_"):
            raise ClosedLoopError("the log has no reference (q_ref_<j> or q_motor_ref_<i>) and no controller is "
                                  "known (meta.options.controller, --controller): IDIM-IV and DIDIM simulate the "
                                  "loop the log was recorded in; use --method ols") from None
        raise exc from None
    ref_q, ref_qd = _references(model, log, ctrl.space)
    time, q, tau = model.joint_signals(log)
    known = model.known_torque(q)
    if known is not None:
        tau = tau - known
    qd = model.joint_velocities(log)
    return LoopLog(np.asarray(time, float), q, tau, qd, ref_q, ref_qd, ctrl, float(log.meta["rate_hz"]))


def progress_line(method: str, it: int, x, dx_rel: float, cost: float | None = None) -> None:
    """Convergence printed on stderr: iteration, relative step, cost."""
    c = "" if cost is None else f", cost {cost:.6g}"
    print(f"[{method}] iteration {it}: |ΔX|/|X| = {dx_rel:.3g}{c}", file=sys.stderr)


def _std_vector(model, cols_std, x) -> np.ndarray:
    """Base values x at their standard columns (W_std X = W_b x_b), the rest 0."""
    X = np.zeros(len(model.standard_names))
    X[cols_std] = x
    return X


def fit_closed_loop(est, logs):
    """IDIM-IV or DIDIM (``est.method``) on one log or a list of logs; fills ``est``'s learned attributes as
    :meth:`tendyn.ident.IDIM.fit` does, plus ``iterations_``, ``converged_``, ``params_ls_``, ``history_``."""
    from tendyn import _core

    from .result import IdentificationResult
    from .lsq import rel_stderr_pct
    from .treatment import default_treatment, parallel_filter_taps, stack_blocks, treat

    method = est.method
    if est.output not in ("torque", "position"):
        raise ValueError(f"output must be 'torque' or 'position' (got {est.output!r})")
    if est.jacobian not in ("idm", "fd"):
        raise ValueError(f"jacobian must be 'idm' or 'fd' (got {est.jacobian!r})")
    if method == "didim" and est.output == "position" and est.jacobian != "fd":
        raise ValueError("DIDIM on positions needs the finite-difference Jacobian (jacobian='fd'): the regressor "
                         "Jacobian is that of the torques")
    if est.essential or est.consistent:
        raise ValueError(f"--method {method} does not combine with --essential or --consistent")
    model = est._model()
    base = model.base
    na = model.n_active
    logs = [logs] if not isinstance(logs, (list, tuple)) else list(logs)
    lls = [closed_loop_data(model, log, est.controller) for log in logs]
    cols = list(range(len(base.names)))
    if est.parameters is not None:
        unknown = [n for n in est.parameters if n not in base.names]
        if unknown:
            raise ValueError(f"not base parameters of {model.device.name}: {', '.join(unknown)}")
        cols = [base.names.index(n) for n in est.parameters]
    cols_std = np.asarray(base.columns)[cols]
    bw = getattr(model.device, "bandwidth_hz", None)

    # measured observations, treated as IDIM-LS treats them (the same Treatment in PARAMS.json)
    per_log = []
    for ll in lls:
        tr = default_treatment(ll.rate_hz, bw, est.cutoff_hz, est.decimate, est.order, est.velocity_threshold)
        qd = None if est.velocities == "differentiate" else ll.qd
        if est.velocities == "logged" and qd is None:
            raise model.no_logged_velocities()
        tr = dataclasses.replace(tr, velocities="differentiate" if qd is None else "logged")
        blocks = treat(model, ll.time, ll.q, ll.tau, tr, qd=qd)
        Y, W, rows = stack_blocks(blocks)
        vel = np.concatenate([b.velocity for b in blocks])
        thr = est._thresholds(blocks)
        keep = np.abs(vel) >= np.repeat(thr, [b.y.size for b in blocks])
        tr = dataclasses.replace(tr, velocity_threshold=tuple(float(v) for v in thr))
        t = np.concatenate([b.time for b in blocks])
        taps = parallel_filter_taps(tr.decimate)
        qdec = None
        if est.output == "position":
            qdec = _core.fir_decimate(taps, tr.decimate, np.ascontiguousarray(ll.q)).T.ravel()
        per_log.append(dict(ll=ll, tr=tr, keep=keep, Y=Y[keep], W=W[:, cols_std][keep], rows=rows[keep], t=t[keep],
                            logged=qd is not None, taps=taps, qdec=qdec))
    est.treatment_ = per_log[-1]["tr"]
    Y = np.concatenate([d["Y"] for d in per_log])
    W = np.vstack([d["W"] for d in per_log])
    rows = np.concatenate([d["rows"] for d in per_log])
    t = np.concatenate([d["t"] for d in per_log])
    x_ls, se_ls, weights = est._solve(W, Y, rows, na, method="wls" if na > 1 else "ols")
    est.params_ls_, est.stderr_ls_ = x_ls, se_ls

    def simulate(X, d):
        ll = d["ll"]
        return simulate_loop(model, X, ll.controller, ll.ref_q, ll.ref_qd, ll.q[0], 1.0 / ll.rate_hz,
                             est.substeps)

    def instruments(x):
        """Z (regressor of the simulated states, treated like W) and the treated simulated torque."""
        Zs, Ts = [], []
        for d in per_log:
            q, qd, _, tau = simulate(_std_vector(model, cols_std, x), d)
            blocks = treat(model, d["ll"].time, q, tau, d["tr"], qd=qd if d["logged"] else None)
            Ys, Zw, _ = stack_blocks(blocks)
            Zs.append(Zw[:, cols_std][d["keep"]])
            Ts.append(Ys[d["keep"]])
        return np.vstack(Zs), np.concatenate(Ts)

    def outputs(xs):
        """Simulated outputs (p, r) of parameter sets xs (p, b): decimated torques (kept rows) or positions."""
        X = np.stack([_std_vector(model, cols_std, x) for x in xs])
        out = []
        for d in per_log:
            q, _, _, tau = simulate(X, d)
            sig = tau if est.output == "torque" else q
            dec = np.stack([_core.fir_decimate(d["taps"], d["tr"].decimate, np.ascontiguousarray(s)).T.ravel()
                            for s in sig])
            out.append(dec[:, d["keep"]] if est.output == "torque" else dec)
        return np.concatenate(out, axis=1)

    x = x_ls.copy()
    history, converged = [], False
    label = method.upper() if method == "iv" else f"DIDIM ({est.output}, {est.jacobian} Jacobian)"
    if method == "iv" or est.jacobian == "idm":
        for it in range(1, int(est.max_iter) + 1):
            Z, Ts = instruments(x)
            cost = float(np.sum(weights * (Y - Ts) ** 2))
            if method == "iv":
                x_new, se, _, _ = instrumental_variables(W, Z, Y, weights)
            else:
                x_new, se, _, _ = least_squares(Z, Y, weights)
            dx = float(np.linalg.norm(x_new - x) / max(np.linalg.norm(x), 1e-300))
            history.append({"iteration": it, "step_rel": dx, "cost": cost})
            progress_line(label, it, x_new, dx, cost)
            x = x_new
            if dx < est.tol:
                converged = True
                break
        if method == "didim":       # σ from the final Jacobian (the regressor of the last simulation)
            _, se, _, _ = least_squares(Z, Y, weights, at=x)
        jac = Z
    else:
        if est.output == "torque":
            y_meas, w_out = Y, weights
        else:
            y_meas = np.concatenate([d["qdec"] for d in per_log])
            w_out = None
        h = 1e-4 * np.maximum(np.abs(x), np.maximum(se_ls, 1e-9))
        cost_of = lambda y, w: float(np.sum((w if w is not None else 1.0) * (y_meas - y) ** 2))
        ys = outputs(x[None])[0]
        if w_out is None:      # positions: each joint's rows weighted by 1/σ² of its starting error
            nrow = y_meas.size // na
            w_out = np.repeat([1.0 / max(np.var(y_meas[j * nrow:(j + 1) * nrow] - ys[j * nrow:(j + 1) * nrow]),
                                         1e-300) for j in range(na)], nrow)
        cost = cost_of(ys, w_out)
        for it in range(1, int(est.max_iter) + 1):
            xs = np.vstack([x, x + np.diag(h)])
            yb = outputs(xs)
            ys = yb[0]
            J = ((yb[1:] - ys) / h[:, None]).T
            e = y_meas - ys
            sw = np.sqrt(w_out)
            step = np.linalg.lstsq(J * sw[:, None], e * sw, rcond=None)[0]
            lam, accepted = 1.0, False
            for _ in range(6):               # step halving: the cost must go down
                trial = x + lam * step
                c_new = cost_of(outputs(trial[None])[0], w_out)
                if c_new <= cost:
                    accepted = True
                    break
                lam *= 0.5
            dx = float(np.linalg.norm(lam * step) / max(np.linalg.norm(x), 1e-300))
            if accepted:
                x, cost = trial, c_new
            history.append({"iteration": it, "step_rel": dx if accepted else 0.0, "cost": cost})
            progress_line(label, it, x, dx if accepted else 0.0, cost)
            if not accepted or dx < est.tol:
                converged = True
                break
        _, se, _, _ = least_squares(J, y_meas - outputs(x[None])[0], w_out, at=np.zeros(x.size))
        jac = J
    est.iterations_, est.converged_, est.history_ = len(history), converged, history
    if not converged:
        print(f"[{label}] not converged after {len(history)} iterations (tol {est.tol:g}): the estimate still "
              "moves; raise --max-iter or check the controller", file=sys.stderr)
    y_hat = W @ x
    est.names_ = [base.names[i] for i in cols]
    est.expressions_ = [base.expression(i, model.standard_names) for i in cols]
    est.params_, est.stderr_ = x, se
    est.rel_stderr_ = rel_stderr_pct(se, x)
    Jw = jac * np.sqrt(weights if jac.shape[0] == weights.size else np.ones(jac.shape[0]))[:, None]
    est.cond_ = float(np.linalg.cond(Jw))
    est.cond_scaled_ = float(np.linalg.cond(Jw / np.linalg.norm(Jw, axis=0)))
    per = [float(np.linalg.norm(Y[rows == j] - y_hat[rows == j]) / max(np.linalg.norm(Y[rows == j]), 1e-300))
           for j in range(na)]
    resid = float(np.linalg.norm(Y - y_hat) / np.linalg.norm(Y))
    _, Ts = instruments(x)
    res = IdentificationResult(model.device.name, method, est.names_, est.expressions_, x, se, est.cond_, Y.size,
                               resid, per, est.treatment_, t, Y, y_hat, rows, model.active_numbers, None,
                               units=[model.unit(n) for n in est.names_])
    res.cond_scaled = est.cond_scaled_
    res.omitted = [n for i, n in enumerate(base.names) if i not in set(cols)]
    res.closed_loop = {"method": method, "output": est.output if method == "didim" else None,
                       "jacobian": est.jacobian if method == "didim" else None,
                       "controller": lls[0].controller.label or lls[0].controller.space + " PID",
                       "iterations": len(history), "converged": converged, "tol": float(est.tol),
                       "history": history,
                       "simulated_torque_residual_rel": float(np.linalg.norm(Y - Ts) / np.linalg.norm(Y)),
                       "ls_start": [{"name": n, "value": float(v), "stderr": float(s)}
                                    for n, v, s in zip(est.names_, x_ls, se_ls)]}
    res.flag_pseudo_inertia(model)
    est.result_ = res
    est._cols = cols
    return est
