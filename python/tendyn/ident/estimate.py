"""Least-squares estimation of the base parameters (IDIM, S2 section III), with statistics.

OLS: X̂ = argmin ‖Y − W X‖, σ̂² = ‖Y − W X̂‖² / (r − b) (the square: ERRATA S2 eq. 5), C = σ̂² (WᵀW)⁻¹,
%σ = 100 σ / |x̂|. WLS: each joint's rows are weighted by 1/σ̂_j from its own OLS residual (r_j − b_j … taken
as r_j − b r_j / r), then OLS on the weighted system. Essential parameters: drop the base parameter with the
worst %σ while the relative residual grows by less than ``essential_tol``. Physically consistent variant:
standard parameters constrained by the pseudo-inertia LMIs (Wensing et al.), friction ≥ 0, solved with cvxpy
and Clarabel; the same statistics are reported at its solution.
"""

from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np


from .lsq import least_squares, rel_stderr_pct, row_factor
from .model import IdentModel, cached_model, diagonal_coupling  # noqa: F401 — cached_model: its home is model.py
from .result import IdentificationResult, implausible, not_physical, precision_warning  # noqa: F401 — their home is result.py
from .treatment import (PRESETS, above_threshold, drop_stale, preset_treatment, stack_blocks, treat,
                        velocity_thresholds)

__all__ = ["IDIM", "IdentificationResult", "least_squares", "VELOCITIES"]

METHODS = ("ols", "wls", "iv", "didim")
"""IDIM estimators: ordinary / weighted least squares, and the closed-loop IDIM-IV and DIDIM
(:mod:`tendyn.ident.closed_loop`)."""
CLOSED_LOOP = ("iv", "didim")

VELOCITIES = ("auto", "logged", "differentiate")
"""Where the joint velocities come from: the log's ``qd_motor_<i>``/``qd_joint_<j>`` when it has them
("auto"), always the log's ("logged"), or the filtered positions differentiated ("differentiate")."""


@dataclasses.dataclass
class TreatedLog:
    """One treated log where it was treated (this process or a Dask worker).

    ``y`` (r,) torques [N·m or N], ``W`` (r, n_standard) standard regressor (None in a light copy), ``rows`` (r,)
    joint index (motor index in motor space), ``time`` (r,) [s], ``samples`` (r,) the sample number in the log,
    joint-major (motor-major), the rows under the velocity threshold dropped; ``n_out`` samples per joint block,
    ``treatment`` the log's. With ``factor``: ``factors`` the compact factor of each joint's rows of the base
    regressor, R of a QR of [W_base | y] (:func:`tendyn.ident.lsq.row_factor`, ‖[W_j | y_j] v‖ = ‖R_j v‖),
    ``counts`` (na,) rows per joint, ``lows``/``highs`` (na,) min/max of y per joint [N·m or N] (range weights).
    """

    y: np.ndarray
    W: np.ndarray | None
    rows: np.ndarray
    time: np.ndarray
    samples: np.ndarray
    n_out: int
    treatment: object
    factors: list | None = None
    counts: np.ndarray | None = None
    lows: np.ndarray | None = None
    highs: np.ndarray | None = None

    def light(self) -> "TreatedLog":
        """Without W: what the client of a Dask campaign needs (the factors and the row vectors)."""
        return dataclasses.replace(self, W=None)

    def predict(self, columns, x) -> np.ndarray:
        """ŷ = W[:, columns] x of the kept rows (columns: standard indices)."""
        return self.W[:, columns] @ x


def treated_log(model, log, parts, settings, factor: bool = False) -> TreatedLog:
    """Treat one log (a Log or a path) and keep its rows above the velocity threshold (each joint's threshold from
    this log's peaks, :func:`velocity_thresholds`), in motor space when the treatment fits there; with ``factor``
    also the per-joint compact factors (:class:`TreatedLog`). The one per-log step of IDIM, in process and on a
    Dask worker alike (the same arithmetic: a campaign gives the same bits either way)."""
    blocks, tr = IDIM._treat_here(model, log, parts, settings)
    Y, W, rows = stack_blocks(blocks)
    t = np.concatenate([b.time for b in blocks])
    vel = np.concatenate([b.velocity for b in blocks])
    thr = velocity_thresholds(tr.velocity_threshold, [np.max(np.abs(b.velocity)) for b in blocks],
                              elastic=model.elastic_drives)
    keep = above_threshold(vel, np.repeat(thr, [b.y.size for b in blocks]))
    tr = dataclasses.replace(tr, velocity_threshold=tuple(float(v) for v in thr))
    n_out = blocks[0].y.size
    samples = np.tile(np.arange(n_out), len(blocks))[keep]
    Y, W, rows, t = Y[keep], W[keep], rows[keep], t[keep]
    if tr.space == "motor":
        Y, W = IDIM._to_motor_space(model, Y, W, rows)
    out = TreatedLog(Y, W, rows, t, samples, n_out, tr)
    if factor:
        na = model.n_active
        Wb = W[:, list(model.base.columns)]
        out.factors = [row_factor(Wb[rows == j], Y[rows == j]) for j in range(na)]
        out.counts = np.bincount(rows, minlength=na)
        out.lows = np.array([Y[rows == j].min() if out.counts[j] else np.inf for j in range(na)])
        out.highs = np.array([Y[rows == j].max() if out.counts[j] else -np.inf for j in range(na)])
    return out


def _treat_logs(device, logs, parts, settings, factor=False):
    """:func:`treated_log` of several logs in one Dask task (a campaign is split into one batch per worker: one
    task, one model look-up and one round trip per batch, not per log); BLAS on one thread as in
    :meth:`IDIM.fit` (the same factors to the bit)."""
    from threadpoolctl import threadpool_limits

    from tendyn.ident.cluster import worker_threads

    model = cached_model(device)
    before, model.threads = model.threads, worker_threads()   # the worker's threads, not every CPU (cluster.py)
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            return [treated_log(model, log, parts, settings, factor) for log in logs]
    finally:
        model.threads = before


def _light_logs(pieces):
    """The light copies (no W) of a batch's treated logs: what goes back to the client."""
    return [p.light() for p in pieces]


def _predict_logs(pieces, columns, x):
    """ŷ of every treated log of a batch, where its W is (BLAS on one thread, as in :meth:`IDIM.fit`)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return [p.predict(columns, x) for p in pieces]


class _Here:
    """Treated logs held in this process."""

    def __init__(self, pieces):
        self.pieces = pieces

    def light(self):
        return self.pieces

    def full(self):
        return self.pieces

    def predict(self, columns, x):
        return [p.predict(columns, x) for p in self.pieces]

    def close(self):
        pass


class _OnDask:
    """Treated logs held on Dask workers (one future per batch): the client fetches the light copies, asks the
    workers for ŷ, and the whole rows only when a fit needs them (:meth:`full`)."""

    def __init__(self, client, own, futures, batches, placements, progress):
        self.client, self.own, self.futures, self.batches, self.kw = client, own, futures, batches, placements
        self.progress = progress

    def _gather(self, futures, counts=None):
        from dask.distributed import as_completed

        index = {f.key: k for k, f in enumerate(futures)}
        done = [None] * len(futures)
        bar = None
        if self.progress and counts is not None:
            from tqdm import tqdm
            bar = tqdm(total=sum(counts), desc="treating logs (dask)", unit="log", file=sys.stderr)
        for fut in as_completed(futures):
            k = index[fut.key]
            done[k] = fut.result()
            if bar is not None:
                bar.update(counts[k])
        if bar is not None:
            bar.close()
        return [r for batch in done for r in batch]

    def light(self):
        return self._gather([self.client.submit(_light_logs, f, pure=False, **kw)
                             for f, kw in zip(self.futures, self.kw)], [len(b) for b in self.batches])

    def full(self):
        return self._gather(self.futures, [len(b) for b in self.batches])

    def predict(self, columns, x):
        return self._gather([self.client.submit(_predict_logs, f, list(columns), np.asarray(x), pure=False, **kw)
                             for f, kw in zip(self.futures, self.kw)])

    def close(self):
        try:
            for f in self.futures:
                f.release()
        finally:
            self.client.close()
            if self.own is not None:
                self.own.close()


@dataclasses.dataclass
class _System:
    """The least squares of a set of treated logs: ``Wb`` (m, n_base), ``Y`` (m,), ``rows`` (m,) joint index of
    each row — the rows themselves (stacked) or the logs' compact factors stacked joint by joint — with
    ``stats`` (counts per joint, (lows, highs) per joint, rows r) for the compact one (None: from the rows);
    the result's rows ``y``, ``row_joint``, ``time`` (joint-major over the logs); ``Wstd`` the standard
    regressor's rows (stacked only); ``predict(cols, x)`` ŷ of the result's rows."""

    Wb: np.ndarray
    Y: np.ndarray
    rows: np.ndarray
    stats: tuple | None
    y: np.ndarray
    row_joint: np.ndarray
    time: np.ndarray
    Wstd: np.ndarray | None
    predict: object
    close: object


def campaign_batches(n_logs: int, n_workers: int) -> list[list[int]]:
    """Log indices split into contiguous batches, one per worker (at most one log per batch when there are
    fewer logs than workers); the batches' results concatenated in order are the logs' in order."""
    k = max(1, min(n_logs, n_workers))
    return [list(map(int, b)) for b in np.array_split(np.arange(n_logs), k) if len(b)]


def motor_space_residual(G, Y, y_hat, rows, samples, n_active, fitted_space: str = "joint") -> list[float] | None:
    """Per motor relative residual ‖y − ŷ‖ / ‖y‖ [-] in motor space, y = G⁻ᵀ τ at every treated sample all the
    active joints keep (joint-major rows of joint torques Y, model ŷ, ``samples`` their sample numbers); None
    for a non-square G or when no sample is kept by every joint. With ``fitted_space="motor"`` the rows are motor
    torques and the result is the other way: per joint, τ = Gᵀ y.

    The fit is in joint space (τ = Gᵀ y, S2 eq. 4 with the motor torques mapped by virtual work) unless a preset
    says motor: the residuals of the fitted space are the ones least squares minimises; the other space's are
    the same errors seen from the other side."""
    G = np.asarray(G, float)
    if G.shape[0] != G.shape[1] or n_active != G.shape[1]:
        return None
    to_other = np.linalg.inv(G.T) if fitted_space == "joint" else G.T
    common = None
    for j in range(n_active):
        s = samples[rows == j]
        common = s if common is None else np.intersect1d(common, s)
    if common is None or common.size == 0:
        return None
    tau = np.empty((common.size, n_active))
    tau_hat = np.empty_like(tau)
    for j in range(n_active):
        sel = rows == j
        idx = np.searchsorted(samples[sel], common)
        tau[:, j], tau_hat[:, j] = Y[sel][idx], y_hat[sel][idx]
    y = tau @ to_other.T                           # motor torques y = G⁻ᵀ τ (or joint τ = Gᵀ y)
    y_h = tau_hat @ to_other.T
    return [float(v) for v in np.linalg.norm(y - y_h, axis=0) / np.maximum(np.linalg.norm(y, axis=0), 1e-300)]


FRICTION_CORRELATION_WARN = 0.95
"""|ρ| of a joint's Coulomb and viscous estimates (FSj, FVj) above which the report warns that the data do not tell
them apart: the two columns are then nearly proportional (one cruise speed per joint), σ only measures the noise,
and any model error (a friction that is not F_C sign(q̇) + F_V q̇ at reversals) moves the split between them."""


def friction_correlation(names, R) -> dict[str, float]:
    """Correlation ρ(FSj, FVj) of each joint's Coulomb and viscous estimates, from the R of the weighted regressor's
    QR (cov ∝ (RᵀR)⁻¹). Keys: the joint's FV name."""
    idx = {n: i for i, n in enumerate(names)}
    pairs = [(idx["FS" + n[2:]], i) for n, i in idx.items() if n.startswith("FV") and "FS" + n[2:] in idx
             and n[2:].isdigit()]
    if not pairs:
        return {}
    try:
        Rinv = np.linalg.inv(np.asarray(R, float))
    except np.linalg.LinAlgError:
        return {}
    C = Rinv @ Rinv.T
    return {names[v]: float(C[s, v] / np.sqrt(C[s, s] * C[v, v])) for s, v in pairs}


def entangled_friction(corr: dict, names, values, stderr, limit: float = FRICTION_CORRELATION_WARN) -> list[str]:
    """One warning line per joint whose Coulomb and viscous estimates are correlated beyond ``limit`` (|ρ|)."""
    val = dict(zip(names, values))
    sig = dict(zip(names, stderr))
    return [f"{fv} = {val[fv]:.4g} ± {sig[fv]:.2g} and FS{fv[2:]}: their estimates are {100 * abs(r):.1f} % "
            f"correlated, so the data do not tell viscous from Coulomb friction on that joint (σ does not show "
            f"it: excite it over a wider range of speeds)" for fv, r in corr.items() if abs(r) > limit]


class IDIM:
    """Inverse-dynamic-model identification by least squares (scikit-learn shape).

    Parameters
    ----------
    device : Device or CompiledDevice
        A serial device (geared ``[[actuators]]``, capstan ``[[drives]]`` or cable ``[[transmissions]]``).
    method : "ols" or "wls"
    cutoff_hz : float or None
        −3 dB cut-off of the zero-phase Butterworth on positions [Hz] (None: 5 × the device bandwidth).
    decimate : int or None
        Decimation factor of the parallel filter (None: rate / (10 × bandwidth)).
    order : int
        Butterworth order.
    velocity_threshold : float or None
        Drop a joint's rows where its |q̇| is below this [rad/s] (the sign of the Coulomb term is undefined
        there); 0 keeps all; None (default): ``DEFAULT_VELOCITY_FRACTION`` of each joint's peak |q̇| in the log.
    velocities : "auto", "logged" or "differentiate"
        Joint velocities from the log's ``qd_motor_<i>`` (or ``qd_joint_<j>``) or from the positions
        (:data:`VELOCITIES`); "auto" uses the logged ones when present. Stale rows (repeats of the previous
        sample) are always dropped and the log re-timed (:func:`tendyn.ident.treatment.drop_stale`).
    essential : bool
        Keep only the essential parameters.
    essential_tol : float
        Allowed relative growth of the relative residual when dropping a parameter.
    consistent : bool or "auto"
        Physically consistent estimate (pseudo-inertia LMIs, cvxpy + Clarabel). "auto" (``tendyn identify``'s
        default): the plain estimate, replaced by the consistent one when it is not physical
        (:func:`not_physical`), with a warning that says so and the plain values in ``result_.plain``.
    scheduler : None, "local" or str
        Where the logs of a campaign are treated: None in this process, ``"local"`` on a local Dask cluster,
        otherwise the address of a Dask scheduler (``tcp://host:8786``).
    progress : bool
        Progress bar (stderr) over the logs.
    parameters : sequence of str or None
        Identify only these base parameters (names of :attr:`IdentModel.base`), the others taken as zero: a
        reduced model such as S2 Table 4's 16 of the 29 (None: all base parameters).
    treatment : str
        The data treatment (:data:`tendyn.ident.treatment.PRESETS`): "tendyn" (default; None is the same) or a
        peer's published one ("janot", "wpi", "figaroh"): its filters, decimation, velocity threshold, velocities,
        trimming, weighting (with ``method="wls"``) and fitting space replace tendyn's defaults; ``cutoff_hz``,
        ``decimate`` and ``velocity_threshold`` given win over the preset's.
    bounds : dict or None
        With ``consistent=True``: box constraints {name: (lower, upper)} on standard parameters (their units) and
        centres of mass ``CX<j>``/``CY<j>``/``CZ<j>`` [m] (:func:`tendyn.ident.consistent.check_bounds`), e.g. a
        peer's hand-chosen boxes; None: the LMIs and non-negative friction and rotor inertias only.
    sdp : dict or None
        With ``consistent=True``: how the consistent problem is posed and solved, the keywords ``form``, ``fixed``,
        ``eps``, ``solve`` of :func:`tendyn.ident.consistent.consistent_fit` (None: tendyn's form, Clarabel), e.g.
        WPI's dVRK SDP solved by WPI's SCS 1.2.6 (benchmarks/realdata/mtm.py).
    drive_stretch : bool
        Elastic capstan ``[[drives]]`` (``stiffness_motor`` > 0, tendyn's treatment, positions differentiated): a
        second least squares on the link positions, the cable stretch taken out of the motor encoders with the
        first fit's friction (:meth:`IdentModel.link_positions`). Without it the viscous terms of a generated
        desktop arm come out +20…+90 % (the rigid model on the motor side misses M (q̈_l − q̈_m / N)).
    """

    def __init__(self, device, method="ols", cutoff_hz=None, decimate=None, order=4, velocity_threshold=None,
                 essential=False, essential_tol=0.02, consistent=False, scheduler=None, progress=False,
                 parameters=None, velocities="auto", treatment="tendyn", controller=None, output="torque",
                 jacobian="idm", max_iter=20, tol=1e-3, substeps=1, bounds=None, drive_stretch=True, sdp=None):
        self.device = device
        self.bounds = bounds
        self.sdp = sdp
        self.drive_stretch = drive_stretch
        self.treatment = treatment
        self.controller = controller
        self.output = output
        self.jacobian = jacobian
        self.max_iter = max_iter
        self.tol = tol
        self.substeps = substeps
        self.velocities = velocities
        self.method = method
        self.cutoff_hz = cutoff_hz
        self.decimate = decimate
        self.order = order
        self.velocity_threshold = velocity_threshold
        self.essential = essential
        self.essential_tol = essential_tol
        self.consistent = consistent
        self.scheduler = scheduler
        self.progress = progress
        self.parameters = parameters

    # -- data ------------------------------------------------------------------------------------------
    def _model(self) -> IdentModel:
        if not hasattr(self, "model_"):
            self.model_ = cached_model(self.device)
        return self.model_

    def observations(self, logs, parts=None):
        """Treated (Y, W_standard, rows, times, n_active) of the logs (every kept row, joint-major over the logs;
        motor-major in motor space); ``parts`` (a, b) keeps the fraction [a, b) of each."""
        S = self._system(logs, parts, compact=False)
        return S.y, S.Wstd, S.row_joint, S.time, self._model().n_active

    def _treated(self, logs, parts, factor, stretch=None):
        """The logs treated one by one (:func:`treated_log`) in this process or on Dask (``scheduler``);
        ``stretch`` (Coulomb, viscous per drive, motor side) takes the capstan cable's stretch out of the motor
        encoders (elastic drives, second pass of :meth:`fit`), None: not."""
        model = self._model()
        if self.velocities not in VELOCITIES:
            raise ValueError(f"velocities must be one of {', '.join(VELOCITIES)} (got {self.velocities!r})")
        settings = (self.cutoff_hz, self.decimate, self.order, self.velocity_threshold, self.treatment,
                    self.velocities, stretch)
        if self.scheduler is not None and len(logs) > 1:
            return self._distributed(logs, parts, settings, factor)
        out = []
        bar = None
        if self.progress and len(logs) > 1:
            from tqdm import tqdm
            bar = tqdm(total=len(logs), desc="treating logs", unit="log", file=sys.stderr)
        for log in logs:
            out.append(treated_log(model, log, parts, settings, factor))
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
        return _Here(out)

    def _system(self, logs, parts=None, compact=False, stretch=None) -> _System:
        """The least squares of the logs (:class:`_System`): their rows stacked, or (``compact``) each log reduced
        to its joints' compact factors where it was treated and only those stacked here (the client of a Dask
        campaign then never holds W: ŷ comes back from the workers); sets ``treatment_`` and ``samples_``. Call
        ``close()`` on the result (a compact one keeps the logs on the workers for ``predict``). ``stretch``: as
        :meth:`_treated`."""
        model = self._model()
        na = model.n_active
        logs = [logs] if not isinstance(logs, (list, tuple)) else list(logs)
        T = self._treated(logs, parts, compact, stretch)
        try:
            pieces = T.light() if compact else T.full()
        except BaseException:
            T.close()
            raise
        self.treatment_ = dataclasses.replace(pieces[-1].treatment,
                                              stale_dropped=sum(p.treatment.stale_dropped for p in pieces),
                                              retimed=any(p.treatment.retimed for p in pieces))
        offsets = np.concatenate([[0], np.cumsum([p.n_out for p in pieces])[:-1]])
        y = np.concatenate([p.y for p in pieces])
        rows = np.concatenate([p.rows for p in pieces])
        t = np.concatenate([p.time for p in pieces])
        order = np.argsort(rows, kind="stable")   # joint-major over all logs
        self.samples_ = np.concatenate([p.samples + o for p, o in zip(pieces, offsets)])[order]
        y, rows, t = y[order], rows[order], t[order]
        base_cols = list(model.base.columns)
        if compact:
            F = np.vstack([p.factors[j] for j in range(na) for p in pieces])     # joint by joint, log by log
            rc = np.repeat(np.arange(na), [sum(p.factors[j].shape[0] for p in pieces) for j in range(na)])
            counts = np.sum([p.counts for p in pieces], axis=0)
            ranges = np.max([p.highs for p in pieces], axis=0) - np.min([p.lows for p in pieces], axis=0)

            def predict(cols, x):
                return np.concatenate(T.predict([base_cols[c] for c in cols], x))[order]

            return _System(F[:, :-1], F[:, -1], rc, (counts, ranges, int(counts.sum())), y, rows, t, None,
                           predict, T.close)
        T.close()
        W = np.vstack([p.W for p in pieces])[order]
        Wb = W[:, base_cols]
        return _System(Wb, y, rows, None, y, rows, t, W, lambda cols, x: Wb[:, cols] @ x, lambda: None)

    @staticmethod
    def _to_motor_space(model, Y, W, rows):
        """Joint-major rows (τ = Gᵀ y, W) → motor-major rows (y = G⁻ᵀ τ, G⁻ᵀ W): the same samples for every joint
        (no velocity threshold); row block i is then motor i."""
        na = model.n_active
        n = rows.size // na
        if rows.size != n * na or np.any(np.bincount(rows, minlength=na) != n):
            raise ValueError("fitting in motor space needs every sample of every joint (velocity threshold 0)")
        GinvT = np.linalg.inv(model.G.T)
        Ym = (GinvT @ Y.reshape(na, n)).reshape(-1)
        Wm = np.einsum("ij,jnb->inb", GinvT, W.reshape(na, n, W.shape[1])).reshape(W.shape)
        return Ym, Wm

    def _thresholds(self, blocks) -> np.ndarray:
        """Per-joint velocity threshold [rad/s]: the given one, or by default (None) the
        ``DEFAULT_VELOCITY_FRACTION`` (elastic drives: ``ELASTIC_VELOCITY_FRACTION``) of each joint's peak |q̇|."""
        tr = getattr(self, "treatment_", None)      # the option given, else the preset's (None: the default rule)
        vt = self.velocity_threshold if tr is None else tr.velocity_threshold
        return velocity_thresholds(vt, [np.max(np.abs(b.velocity)) for b in blocks],
                                   elastic=self._model().elastic_drives)

    @staticmethod
    def _treat_here(model, log, parts, settings):
        from tendyn.io import read_log

        if not hasattr(log, "meta"):
            log = read_log(log)
        *settings, preset, velocities, stretch = settings
        rate = float(log.meta["rate_hz"])
        preset = preset or "tendyn"
        bw = getattr(model.device, "bandwidth_hz", None)
        tr = preset_treatment(preset, rate, bw, *settings,      # the options given win over the preset's
                              elastic=model.elastic_drives)
        if "velocities" in PRESETS[preset].fields(rate, bw):     # a preset that says which velocities it uses
            velocities = tr.velocities
        time, q, tau = model.joint_signals(log)
        qd = None if velocities == "differentiate" else model.joint_velocities(log)
        if stretch is not None and velocities != "logged":   # elastic capstan drives: the link (link_positions)
            q, qd = model.link_positions(q, tau, rate, tr.cutoff_hz, tr.order, *stretch), None
        if velocities == "logged" and qd is None:
            raise model.no_logged_velocities()
        if parts is not None:
            n = time.size
            sl = slice(int(parts[0] * n), int(parts[1] * n))
            time, q, tau = time[sl], q[sl], tau[sl]
            qd = None if qd is None else qd[sl]
        if tr.keep_stale:
            n_stale, retimed = 0, False
        else:
            time, q, tau, qd, n_stale, retimed = drop_stale(time, rate, q, tau, qd)
        known = model.known_torque(q)         # [[terms]] of kind "known": subtracted, not identified
        if known is not None:
            tau = tau - known
        tr = dataclasses.replace(tr, velocities="differentiate" if qd is None else "logged", stale_dropped=n_stale,
                                 retimed=retimed)
        return treat(model, time, q, tau, tr, qd=qd), tr

    def _distributed(self, logs, parts, settings, factor=False) -> _OnDask:
        """Treat the logs on Dask workers (a local cluster, or the scheduler at ``self.scheduler``): one task per
        worker, whose treated logs stay there (:class:`_OnDask`)."""
        from dask.distributed import Client

        from tendyn.progress import quiet_dask

        quiet_dask()                                    # no nanny/worker warnings unless --debug
        dev = self._model().device
        own = None
        if self.scheduler == "local":
            from tendyn.ident.cluster import local_cluster

            own = local_cluster(min(len(logs), os.cpu_count() or 1))
            client = Client(own)
        else:
            from tendyn.ident.cluster import connect_scheduler

            client = connect_scheduler(self.scheduler)     # ConnectionError naming the address
        try:
            shipped = client.scatter(dev, broadcast=True)      # the device goes to each worker once
            workers = len(client.scheduler_info().get("workers", {})) or len(logs)
            batches = campaign_batches(len(logs), workers)
            from tendyn.ident.cluster import placement

            kws = placement(client, len(batches))
            futures = [client.submit(_treat_logs, shipped, [logs[i] for i in b], parts, settings, factor,
                                     pure=False, **kw) for b, kw in zip(batches, kws)]
        except BaseException:
            client.close()
            if own is not None:
                own.close()
            raise
        return _OnDask(client, own, futures, batches, kws, self.progress)

    # -- fit -------------------------------------------------------------------------------------------
    def _solve(self, Wb, Y, rows, na, method=None, stats=None):
        """OLS / WLS on rows (``stats`` None) or on stacked compact factors (``stats`` = rows per joint, range of
        y per joint, rows r: what the factors do not say); returns (x, stderr, weights of Wb's rows)."""
        method = self.method if method is None else method
        n_obs = None if stats is None else stats[2]
        x, se, s2, cov = least_squares(Wb, Y, n_obs=n_obs)
        weights = np.ones_like(Y)
        if method == "wls" and getattr(self, "treatment_", None) is not None \
                and self.treatment_.weighting == "range":        # a peer's weights: 1 / range of each block
            for j in range(na):
                sel = rows == j
                rng = float(np.ptp(Y[sel])) if stats is None else float(stats[1][j])
                weights[sel] = 1.0 / max(rng, 1e-300)
            x, se, s2, cov = least_squares(Wb * weights[:, None], Y * weights, n_obs=n_obs)
        elif method == "wls":
            r, b = Wb.shape
            r = r if stats is None else stats[2]
            res = Y - Wb @ x
            for j in range(na):
                sel = rows == j
                rj = int(sel.sum()) if stats is None else int(stats[0][j])
                sj2 = float(res[sel] @ res[sel]) / max(rj - b * rj / r, 1.0)
                weights[sel] = 1.0 / np.sqrt(sj2)
            x, se, s2, cov = least_squares(Wb * weights[:, None], Y * weights, n_obs=n_obs)
        elif method != "ols":
            raise ValueError(f"method must be one of {', '.join(METHODS)} (got {method!r})")
        return x, se, weights

    def fit(self, logs, crossval=True):
        """Identify the base parameters from one log or a list of logs; returns self (see :meth:`_fit`).

        The linear algebra here is on small matrices (b ≈ 60 columns): BLAS runs on one thread, which on a
        shared 2-core machine measured 3x faster than its default thread pool (0.78 s vs 2.4 s, TX40 log).
        """
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            return self._fit(logs, crossval)

    def _fit(self, logs, crossval=True):
        """Identify the base parameters from one log or a list of logs; returns self.

        Learned: ``params_`` (base values), ``stderr_``, ``rel_stderr_`` [%], ``cond_``, ``names_``,
        ``expressions_``, ``result_`` (:class:`IdentificationResult`), ``treatment_``.
        """
        if self.bounds and self.consistent is not True:
            raise ValueError("bounds need consistent=True (they constrain the physically consistent fit)")
        if self.consistent == "auto":
            return self._fit_auto(logs, crossval)
        if self.method in CLOSED_LOOP:
            from .closed_loop import fit_closed_loop

            if (self.treatment or "tendyn") != "tendyn":
                raise ValueError(f"treatment {self.treatment!r} is not available with method {self.method!r} "
                                 "(tendyn's treatment only)")

            return fit_closed_loop(self, logs)
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)} (got {self.method!r})")
        model = self._model()
        base = model.base
        na = model.n_active
        cols = list(range(len(base.names)))
        if self.parameters is not None:
            unknown = [n for n in self.parameters if n not in base.names]
            if unknown:
                raise ValueError(f"not base parameters of {model.device.name}: {', '.join(unknown)} "
                                 f"(base: {', '.join(base.names)})")
            cols = [base.names.index(n) for n in self.parameters]
        # each log reduced to compact factors where it is treated (lsq.row_factor; the same arithmetic in process
        # and on Dask); the consistent fit needs the standard regressor's rows: stacked
        compact = not self.consistent
        S = self._system(logs, compact=compact)
        stretch = None                      # the drives' friction the second pass takes the cable stretch with
        try:
            x, se, weights = self._solve(S.Wb[:, cols], S.Y, S.rows, na, stats=S.stats)
            if self.drive_stretch and model.elastic_drives and (self.treatment or "tendyn") == "tendyn":
                # second pass on the link positions: the cable stretch from the motor equation with this fit's
                # friction
                val = dict(zip([base.names[i] for i in cols], x))
                N = np.array([d.ratio for d in model.device.drives], float)
                num = [d.joint for d in model.device.drives]
                stretch = (np.array([max(val.get(f"FS{j}", 0.0), 0.0) for j in num]) / N,
                           np.array([max(val.get(f"FV{j}", 0.0), 0.0) for j in num]) / N ** 2)
                S.close()
                S = self._system(logs, compact=compact, stretch=stretch)
                x, se, weights = self._solve(S.Wb[:, cols], S.Y, S.rows, na, stats=S.stats)
            if self.essential:
                cols, x, se, weights = self._essential(S.Wb, S.Y, S.rows, na, S.stats)
            Wsel = S.Wb[:, cols]
            if self.consistent:
                from .consistent import consistent_fit

                xs = consistent_fit(model, S.Wstd * weights[:, None], S.Y * weights, bounds=self.bounds,
                                    **(self.sdp or {}))
                self.standard_params_ = dict(zip(model.standard_names, map(float, xs)))
                x = (base.combination @ xs)[cols]
                _, se, _, _ = least_squares(Wsel * weights[:, None], S.Y * weights, at=x)
            y_hat = S.predict(cols, x)
        finally:
            S.close()
        Y, rows, t = S.y, S.row_joint, S.time
        self.names_ = [base.names[i] for i in cols]
        self.expressions_ = [base.expression(i, model.standard_names) for i in cols]
        self.params_, self.stderr_ = x, se
        self.rel_stderr_ = rel_stderr_pct(se, x)
        Ww = Wsel * weights[:, None]           # the weighted rows, or their compact factors: the same R
        # cond(W) and cond(W D) (D: unit columns) from one QR: W = Q R, the same singular values as R, half the
        # CPU of two SVDs of the tall W (the client's serial share of a Dask campaign, docs/design.md)
        R = np.linalg.qr(Ww, mode="r")
        sv = np.linalg.svd(R, compute_uv=False)
        svs = np.linalg.svd(R / np.linalg.norm(Ww, axis=0), compute_uv=False)
        self.cond_ = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
        self.cond_scaled_ = float(svs[0] / svs[-1]) if svs[-1] > 0 else float("inf")
        per = [float(np.linalg.norm(Y[rows == j] - y_hat[rows == j]) / max(np.linalg.norm(Y[rows == j]), 1e-300))
               for j in range(na)]
        resid = float(np.linalg.norm(Y - y_hat) / np.linalg.norm(Y))
        space = self.treatment_.space
        other = motor_space_residual(model.G, Y, y_hat, rows, self.samples_, na, space)
        per, per_motor = (per, other) if space == "joint" else (other, per)
        # cross-validation on the same (link) positions as the fit
        cv = self._crossval(logs, cols, stretch) if crossval else None
        method = self.method + ("+consistent" if self.consistent else "") + ("+essential" if self.essential else "")
        self.result_ = IdentificationResult(model.device.name, method, self.names_, self.expressions_, x, se,
                                            self.cond_, Y.size, resid, per, self.treatment_, t, Y, y_hat, rows,
                                            model.active_numbers, cv, units=[model.unit(n) for n in self.names_])
        self.result_.cond_scaled = self.cond_scaled_
        self.result_.per_motor_residual_rel = per_motor
        self.result_.residual_space = space
        self.result_.coupled = not diagonal_coupling(model.G)
        self.result_.omitted = [n for i, n in enumerate(base.names) if i not in set(cols)]
        self.result_.flag_pseudo_inertia(model)
        self.result_.friction_correlation = friction_correlation(self.names_, R)
        self.result_.warnings += entangled_friction(self.result_.friction_correlation, self.names_, x, se)
        self._cols = cols
        return self

    def _fit_auto(self, logs, crossval):
        """``consistent="auto"``: the plain fit, then the consistent one when the plain is not physical."""
        self.consistent = False
        try:
            self._fit(logs, crossval)
            plain = self.result_
            if not not_physical(plain) or self.method in CLOSED_LOOP:
                return self
            self.consistent = True
            self._fit(logs, crossval)
        finally:
            self.consistent = "auto"
        res = self.result_
        res.plain = plain
        why = [w for w in plain.warnings if not precision_warning(w)] or plain.warnings
        res.warnings.insert(0, "the plain least squares is not physical (" + "; ".join(why)[:400]
                            + "): the physically consistent estimate (pseudo-inertia LMIs) is reported instead "
                              "(--plain: the plain one)")
        return self

    def _essential(self, Wb, Y, rows, na, stats=None):
        """Drop the worst-%σ parameter while the relative residual grows by less than ``essential_tol`` (rows or
        compact factors: ‖Y − W x‖ and ‖Y‖ are the same on both)."""
        cols = list(range(Wb.shape[1]))
        x, se, w = self._solve(Wb, Y, rows, na, stats=stats)
        r0 = np.linalg.norm(Y - Wb @ x) / np.linalg.norm(Y)
        while len(cols) > 1:
            rel = rel_stderr_pct(se, x)
            worst = int(np.argmax(rel))
            trial = cols[:worst] + cols[worst + 1:]
            xt, st, wt = self._solve(Wb[:, trial], Y, rows, na, stats=stats)
            rt = np.linalg.norm(Y - Wb[:, trial] @ xt) / np.linalg.norm(Y)
            if rt > (1 + self.essential_tol) * r0 or rel[worst] < 1.0:
                break
            cols, x, se, w = trial, xt, st, wt
        return cols, x, se, w

    def _crossval(self, logs, cols, stretch=None):
        """Fit on the first half (or all logs but the last), predict the other part: relative residual (on the
        link positions of the fit's ``stretch``, :meth:`_treated`)."""
        logs = [logs] if not isinstance(logs, (list, tuple)) else list(logs)
        base = self._model().base
        if len(logs) >= 2:
            fitp, valp, desc = (logs[:-1], None), (logs[-1:], None), ("all logs but the last", "the last log")
        else:
            fitp, valp, desc = (logs, (0.0, 0.5)), (logs, (0.5, 1.0)), ("first half", "second half")
        na = self._model().n_active
        compact = not self.consistent           # as in _fit: the consistent fit needs the rows
        S = self._system(*fitp, compact=compact, stretch=stretch)
        S.close()
        x, _, w = self._solve(S.Wb[:, cols], S.Y, S.rows, na, stats=S.stats)
        if self.consistent:        # the same estimator on the first part
            from .consistent import consistent_fit

            x = (base.combination @ consistent_fit(self._model(), S.Wstd * w[:, None], S.Y * w,
                                                   bounds=self.bounds, **(self.sdp or {})))[cols]
        V = self._system(*valp, compact=compact, stretch=stretch)
        V.close()
        Yv, rv = V.Y, V.rows                    # per joint ‖y − W x‖ and ‖y‖: the same on rows and factors
        res = Yv - V.Wb[:, cols] @ x
        per = [float(np.linalg.norm(res[rv == j]) / max(np.linalg.norm(Yv[rv == j]), 1e-300)) for j in range(na)]
        return {"fit": desc[0], "validate": desc[1], "residual_rel": float(np.linalg.norm(res) / np.linalg.norm(Yv)),
                "per_joint_residual_rel": per, "params": [float(v) for v in x]}

    def identified_model(self):
        """The fitted parameters as a :class:`tendyn.ident.identified.IdentifiedModel` (save, load, predict a
        log's torques at its own time stamps, score)."""
        from .identified import IdentifiedModel

        d = self.result_.to_dict()
        return IdentifiedModel(self._model().device, d["params"], d["method"], d["treatment"])

    def predict(self, log, filter_prediction: bool = True):
        """Joint and motor torques of a log predicted with the fitted parameters, one per sample at the log's
        own time stamps (:class:`tendyn.ident.identified.TorquePrediction`, :meth:`IdentifiedModel.predict`)."""
        return self.identified_model().predict(log, filter_prediction)

    def score(self, log) -> np.ndarray:
        """Per joint relative error ‖τ − τ̂‖ / ‖τ‖ [-] of a log (:meth:`predict`)."""
        return self.identified_model().score(log)

    def get_params(self, deep: bool = True) -> dict:
        """The hyper-parameters given to ``__init__`` (scikit-learn's contract)."""
        import inspect

        return {k: getattr(self, k) for k in inspect.signature(type(self).__init__).parameters if k != "self"}

    def set_params(self, **params) -> "IDIM":
        """Change hyper-parameters by name; returns self. An unknown name raises ValueError."""
        known = self.get_params()
        for k, v in params.items():
            if k not in known:
                raise ValueError(f"{type(self).__name__} has no parameter {k!r} (known: {', '.join(known)})")
            setattr(self, k, v)
        return self
