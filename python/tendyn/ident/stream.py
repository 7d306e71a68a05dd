"""Identification of logs too large for memory: chunk by chunk, never holding W.

Each chunk of samples is filtered with an overlap on both sides (the zero-phase Butterworth of the positions
looks forward and backward; an overlap of many time constants makes the chunked result equal to the
in-memory one to rounding), differentiated, turned into decimated regressor rows by the core on the global
decimation grid (output k centred on input h + k K, the same samples as in memory), and reduced to the
normal equations per joint block: Wⱼᵀ Wⱼ, Wⱼᵀ Yⱼ, Yⱼᵀ Yⱼ, rⱼ. OLS, WLS, σ̂², the covariance, cond(W) and the
per-joint residuals all follow from these sums.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .estimate import IDIM
from .lsq import least_squares, rel_stderr_pct
from .model import IdentModel
from .treatment import (above_threshold, butter_zero_phase, central_differences, default_treatment,
                        parallel_filter_taps, velocity_thresholds)

__all__ = ["NormalEquations", "accumulate", "iter_parquet_chunks", "prefetch", "solve_normal"]


class NormalEquations:
    """Per-joint sums of the observation system: A[j] = Wⱼᵀ Wⱼ, B[j] = Wⱼᵀ Yⱼ, C[j] = Yⱼᵀ Yⱼ, r[j] rows."""

    def __init__(self, n_joints: int, n_params: int):
        self.A = np.zeros((n_joints, n_params, n_params))
        self.B = np.zeros((n_joints, n_params))
        self.C = np.zeros(n_joints)
        self.r = np.zeros(n_joints, dtype=np.int64)

    def add(self, j: int, W: np.ndarray, y: np.ndarray) -> None:
        self.A[j] += W.T @ W
        self.B[j] += W.T @ y
        self.C[j] += y @ y
        self.r[j] += y.size

    def merge(self, other: "NormalEquations") -> "NormalEquations":
        self.A += other.A; self.B += other.B; self.C += other.C; self.r += other.r
        return self


def solve_normal(ne: NormalEquations, method: str = "ols"):
    """(x, stderr, cond, residual_rel, per_joint_residual_rel) from the accumulated sums, by the one least
    squares (:func:`tendyn.ident.lsq.least_squares` on the normal equations); WLS weights each joint by
    1/σ̂ⱼ of its own OLS residual, as in memory."""
    def ls(weights):
        w2 = weights ** 2
        A = np.tensordot(w2, ne.A, 1)
        B = np.tensordot(w2, ne.B, 1)
        x, se, _, _ = least_squares(normal=(A, B, float(w2 @ ne.C), r))
        rss_j = ne.C - 2 * ne.B @ x + np.einsum("i,jik,k->j", x, ne.A, x)
        return x, se, A, np.maximum(rss_j, 0.0)

    nj, b = ne.B.shape
    r = int(ne.r.sum())
    w = np.ones(nj)
    x, se, A, rss = ls(w)
    if method == "wls":
        s2j = rss / np.maximum(ne.r - b * ne.r / r, 1.0)
        w = 1.0 / np.sqrt(s2j)
        x, se, A, rss = ls(w)
    ev = np.linalg.eigvalsh(A)
    cond = float(np.sqrt(ev[-1] / ev[0]))
    per = np.sqrt(rss / ne.C)
    return x, se, cond, float(np.sqrt(rss.sum() / ne.C.sum())), per


def accumulate(model: IdentModel, chunks, rate_hz: float, treatment=None, overlap: int | None = None,
               columns=None, split_at: int | None = None, velocity_threshold=None, peak_only: bool = False):
    """Normal equations of a log given as an iterator of (time, q, tau) chunks (joint signals, in order).

    ``overlap`` input samples are kept on each side of a chunk for the Butterworth filter (default: 40 time
    constants of its slowest pole, τ = 1 / (sin(π / 2n) 2π f_c), plus the FIR half-length: e^-40 of the
    edge transient reaches the kept samples, so chunks reproduce the in-memory filter to rounding).
    ``split_at`` (a decimated output index): return ((rows before, rows from there on), treatment) instead of
    (all rows, treatment) — the two halves of a cross-validation in the same pass.
    ``velocity_threshold`` (n_active,) [rad/s]: a joint's rows whose decimated filtered |q̇| is below its value
    are left out, as in memory (:meth:`tendyn.ident.IDIM.observations`); None keeps all.
    ``peak_only``: no regressor; return (peak decimated |q̇| per joint [rad/s], treatment), the pass that
    sets the default threshold.
    """
    tr = treatment or default_treatment(rate_hz, getattr(model.device, "bandwidth_hz", None))
    taps = parallel_filter_taps(tr.decimate)
    K, h = tr.decimate, (taps.size - 1) // 2
    if overlap is None:
        tau = 1.0 / (np.sin(np.pi / (2 * tr.order)) * 2 * np.pi * tr.cutoff_hz)
        overlap = int(40 * tau * tr.rate_hz) + h + 2
    cols = model.base.columns if columns is None else columns
    ne = NormalEquations(model.n_active, len(cols))
    ne_b = NormalEquations(model.n_active, len(cols))
    peak = np.zeros(model.n_active)
    thr = None if velocity_threshold is None else np.broadcast_to(np.asarray(velocity_threshold, float),
                                                                   (model.n_active,))
    dt = 1.0 / tr.rate_hz
    buf_t = buf_q = buf_tau = buf_qd = None
    start = 0                   # global index of buf[0]
    next_k = 0                  # next global output index to produce
    done = False
    it = iter(chunks)
    while not done:
        try:
            t, q, tau, *rest = next(it)
            qd_in = rest[0] if rest else None        # logged joint velocities [rad/s], or None
            if buf_t is None:
                buf_t, buf_q, buf_tau, buf_qd = t, q, tau, qd_in
            else:
                buf_t = np.concatenate([buf_t, t]); buf_q = np.vstack([buf_q, q]); buf_tau = np.vstack([buf_tau, tau])
                buf_qd = None if qd_in is None else np.vstack([buf_qd, qd_in])
        except StopIteration:
            done = True
        if buf_t is None:
            return (peak if peak_only else (ne, ne_b) if split_at is not None else ne), tr
        n = buf_t.size
        end_global = start + n            # exclusive
        # centre samples c = h + kK we may produce now: full FIR window and the filter's overlap on the right
        right_ok = end_global if done else end_global - overlap
        k_hi = (right_ok - 1 - h - h) // K if right_ok - 1 - 2 * h >= 0 else -1     # window [c-h, c+h] < right_ok
        if k_hi >= next_k:
            qf = butter_zero_phase(buf_q, tr.cutoff_hz, tr.rate_hz, tr.order)
            qd = central_differences(qf, dt) if buf_qd is None else \
                butter_zero_phase(buf_qd, tr.cutoff_hz, tr.rate_hz, tr.order)    # as in memory (treat)
            qdd = central_differences(qd, dt)
            lo = next_k * K - start               # local index of the first window start
            hi = k_hi * K + 2 * h + 1 - start     # local exclusive end of the last window
            from tendyn import _core
            vdec = _core.fir_decimate(taps, K, np.ascontiguousarray(qd[lo:hi]))
            if peak_only:
                peak = np.maximum(peak, np.max(np.abs(vdec), axis=0))
                next_k = k_hi + 1
            else:
                W = model.regressor(qf[lo:hi], qd[lo:hi], qdd[lo:hi], taps, K)
                ydec = _core.fir_decimate(taps, K, np.ascontiguousarray(buf_tau[lo:hi]))
                n_out = ydec.shape[0]
                Wb = W[:, list(cols)]
                cut = n_out if split_at is None else int(np.clip(split_at - next_k, 0, n_out))
                for j in range(model.n_active):
                    Wj, yj = Wb[j * n_out:(j + 1) * n_out], ydec[:, j]
                    keep = np.ones(n_out, bool) if thr is None else above_threshold(vdec[:, j], thr[j])
                    if cut > 0:
                        ne.add(j, Wj[:cut][keep[:cut]], yj[:cut][keep[:cut]])
                    if cut < n_out:
                        ne_b.add(j, Wj[cut:][keep[cut:]], yj[cut:][keep[cut:]])
                next_k = k_hi + 1
        # drop what no future output needs (keep the filter overlap before the next window)
        keep_from = max(0, min(next_k * K - start - overlap, n))
        if keep_from > 0:
            buf_t, buf_q, buf_tau = buf_t[keep_from:], buf_q[keep_from:], buf_tau[keep_from:]
            buf_qd = None if buf_qd is None else buf_qd[keep_from:]
            start += keep_from
    return (peak if peak_only else (ne, ne_b) if split_at is not None else ne), tr




def iter_parquet_chunks(model: IdentModel, path, rows: int = 500_000, torques: bool = True, velocities=None):
    """(time, q, tau, qd) chunks of a Parquet log, batch by batch (pyarrow), joint signals as in
    :meth:`IdentModel.joint_signals`; ``torques=False`` reads no torque column (tau has no column: the
    pass that only looks at the speeds); ``velocities``: the columns of :meth:`IdentModel.velocity_columns` to read as
    the joint velocities qd [rad/s] (None: qd is None)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from tendyn.io.logs import LogError

    nm = model.n_motors
    names = stream_columns(model, torques) + list(velocities or [])
    try:        # pages verified against their checksums, as read_log does: corrupted bytes are refused
        f = pq.ParquetFile(str(path), page_checksum_verification=True)
    except (pa.ArrowException, OSError) as exc:
        raise LogError(f"not a readable Parquet file: {exc}", file=str(path)) from None
    missing = [n for n in names if n not in f.schema_arrow.names]
    if missing:
        raise LogError(f"identification needs {', '.join(missing)}", file=str(path), column=missing[0])
    Ginv = np.linalg.inv(model.G)
    nt = nm if torques else 0
    # row group by row group: a reader over the whole file pre-buffers ahead and holds memory in proportion
    # to the file (measured: all of a 3 M-sample log); one group at a time holds at most one group
    batches = (b for g in range(f.num_row_groups)
               for b in f.iter_batches(batch_size=rows, row_groups=[g], columns=names, use_threads=False))
    done = 0
    while True:
        try:
            batch = next(batches, None)
        except (pa.ArrowException, OSError) as exc:
            raise LogError(f"not a readable Parquet file: {exc}", file=str(path)) from None
        if batch is None:
            return
        cols = [np.asarray(batch.column(k).to_numpy(zero_copy_only=False), dtype=float) for k in range(len(names))]
        for name, c in zip(names, cols):            # nulls and non-finite values: what read_log refuses
            bad = ~np.isfinite(c)
            if bad.any():
                raise LogError("missing or non-finite value", file=str(path), column=name,
                               row=done + int(np.argmax(bad)))
        done += cols[0].size
        t = cols[0]
        qm = np.column_stack(cols[1:1 + nm])
        y = np.column_stack(cols[1 + nm:1 + nm + nt]) @ model.G if torques else np.empty((t.size, 0))
        qd = None
        if velocities:
            v = np.column_stack(cols[1 + nm + nt:])
            qd = v @ Ginv.T if velocities[0].startswith("qd_motor_") else v
        yield t, qm @ Ginv.T + model.joint_offsets, y, qd


class StaleScan:
    """Iterate (time, q, tau, …) chunks unchanged while counting what :func:`tendyn.ident.treatment.drop_stale`
    would do: stale rows (a row whose q and τ equal the previous row's) and whether the stamps lie within
    RETIME_TOLERANCE of t₀ + k / rate. It rides on another pass over the log (the speed pass), so a clean log
    is not read once more for it; :meth:`result` after the iteration."""

    def __init__(self, chunks, rate_hz: float):
        self.chunks, self.rate_hz = chunks, float(rate_hz)
        self.n_stale = self.n = 0
        self.t0 = self.t_last = None
        self.worst = 0.0                   # largest |stamp − grid| [s]

    def __iter__(self):
        prev = None
        for chunk in self.chunks:
            t, q, tau = chunk[:3]
            if t.size:
                if self.t0 is None:
                    self.t0 = float(t[0])
                qq = q if prev is None else np.vstack([prev[0], q])
                tt = tau if prev is None else np.vstack([prev[1], tau])
                self.n_stale += int(np.sum(np.all(qq[1:] == qq[:-1], axis=1) & np.all(tt[1:] == tt[:-1], axis=1)))
                grid = self.t0 + (1.0 / self.rate_hz) * (self.n + np.arange(t.size))
                self.worst = max(self.worst, float(np.max(np.abs(t - grid))))
                self.n += t.size
                self.t_last = float(t[-1])
                prev = (q[-1:], tau[-1:])
            yield chunk

    def result(self):
        """(stale rows, samples, first and last time [s], on the uniform grid)."""
        from .treatment import RETIME_TOLERANCE

        if self.t0 is None:
            return 0, 0, 0.0, 0.0, True
        n_grid = int(np.round((self.t_last - self.t0) * self.rate_hz)) + 1
        on_grid = n_grid == self.n and self.worst <= RETIME_TOLERANCE / self.rate_hz
        return self.n_stale, self.n, self.t0, self.t_last, on_grid


def retime_chunks(chunks, rate_hz: float, t0: float, t_last: float):
    """The chunks with their stale rows dropped and the rest interpolated onto t₀ + k / rate, k = 0 …
    round((t_last − t₀) rate): chunk by chunk, carrying the last kept row across chunk borders, so the result
    equals :func:`tendyn.ident.treatment.drop_stale` on the whole log."""
    n_grid = int(np.round((t_last - t0) * rate_hz)) + 1
    k = 0
    last = None                                   # last kept row: (t, q, tau, qd)

    def interp(g, tk, x):
        return None if x is None else np.column_stack([np.interp(g, tk, x[:, j]) for j in range(x.shape[1])])

    for t, q, tau, *rest in chunks:
        qd = rest[0] if rest else None
        if t.size == 0:
            continue
        qq = q if last is None else np.vstack([last[1], q])
        tt = tau if last is None else np.vstack([last[2], tau])
        stale = np.all(qq[1:] == qq[:-1], axis=1) & np.all(tt[1:] == tt[:-1], axis=1)
        keep = ~stale if last is not None else np.concatenate([[True], ~stale])
        kt, kq, ktau = t[keep], q[keep], tau[keep]
        kqd = None if qd is None else qd[keep]
        if last is not None:
            kt = np.concatenate([last[0], kt]); kq = np.vstack([last[1], kq]); ktau = np.vstack([last[2], ktau])
            kqd = None if kqd is None else np.vstack([last[3], kqd])
        if kt.size == 0:
            continue
        last = (kt[-1:], kq[-1:], ktau[-1:], None if kqd is None else kqd[-1:])
        hi = min(n_grid, int(np.floor((kt[-1] - t0) * rate_hz + 1e-9)) + 1)     # grid points ≤ last kept
        if hi > k:
            g = t0 + (1.0 / rate_hz) * np.arange(k, hi)       # the grid of drop_stale, to the bit
            yield g, interp(g, kt, kq), interp(g, kt, ktau), interp(g, kt, kqd)
            k = hi
    if last is not None and k < n_grid:           # beyond the last kept stamp: held (np.interp clamps)
        g = t0 + (1.0 / rate_hz) * np.arange(k, n_grid)
        m = g.size
        yield g, np.repeat(last[1], m, 0), np.repeat(last[2], m, 0), \
            None if last[3] is None else np.repeat(last[3], m, 0)


def subtract_known(model: IdentModel, chunks):
    """The chunks with the ``known`` terms' torques subtracted from τ (after re-timing, as in memory)."""
    for t, q, tau, *rest in chunks:
        known = model.known_torque(q) if tau.shape[1] else None
        yield (t, q, tau if known is None else tau - known, *rest)


def stream_columns(model: IdentModel, torques: bool = True) -> list[str]:
    """The columns a streamed identification reads: time, the motor positions and (``torques``) torques."""
    nm = model.n_motors
    return ["time"] + [f"q_motor_{i + 1}" for i in range(nm)] + \
        ([f"torque_motor_{i + 1}" for i in range(nm)] if torques else [])


def prefetch(chunks, depth: int = 1):
    """Iterate ``chunks`` with the next one read in a background thread while the caller works on this one.

    The core's regressor releases the GIL, so reading and decoding the next Parquet batch (Python, pyarrow)
    overlaps the C++ work on the current one. At most ``depth`` chunks wait ahead (memory stays bounded).
    An exception of the reader is raised in the caller at the chunk where it happened.
    """
    import queue
    import threading

    q: queue.Queue = queue.Queue(maxsize=depth)
    done = object()
    stop = threading.Event()

    def read():
        try:
            for c in chunks:
                while not stop.is_set():
                    try:
                        q.put((c, None), timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put((done, None))
        except BaseException as exc:       # handed to the caller
            q.put((done, exc))

    th = threading.Thread(target=read, name="tendyn-prefetch", daemon=True)
    th.start()
    try:
        while True:
            item, exc = q.get()
            if item is done:
                if exc is not None:
                    raise exc
                return
            yield item
    finally:
        stop.set()
        th.join()


class StreamingIDIM:
    """OLS/WLS identification of a Parquet log too large for memory (the contract of :class:`IDIM`).

    Parameters
    ----------
    device : Device or CompiledDevice
    method : "ols" or "wls"
    cutoff_hz, decimate, order, velocity_threshold, velocities : the treatment options of
        :class:`tendyn.ident.IDIM`, honoured the same way (defaults from the rate and bandwidth; the default
        threshold, a fraction of each joint's peak speed, costs a first pass over q, τ and the logged speeds
        that also counts the stale rows; when the log has them or is off its grid, it is re-timed as in memory
        and the speed pass is run again on the re-timed batches)
    chunk_rows : int
        Samples read per Parquet batch.

    ``fit(path)`` reads the log batch by batch, accumulates the per-joint normal equations and solves them;
    learned: ``params_``, ``stderr_``, ``rel_stderr_``, ``cond_``, ``names_``, ``treatment_``, ``result_``.
    The cross-validation fits the first half of the samples and predicts the second (two accumulations).
    """

    def __init__(self, device, method="ols", cutoff_hz=None, decimate=None, order=4, chunk_rows=500_000,
                 velocity_threshold=None, velocities="auto"):
        self.device = device
        self.velocity_threshold = velocity_threshold
        self.method = method
        self.cutoff_hz = cutoff_hz
        self.decimate = decimate
        self.order = order
        self.chunk_rows = chunk_rows
        self.velocities = velocities

    # the IDIM's contract: hyper-parameters, prediction and score of a log with the fitted parameters
    get_params, set_params, predict, score = IDIM.get_params, IDIM.set_params, IDIM.predict, IDIM.score

    def identified_model(self):
        """The fitted parameters as a :class:`tendyn.ident.identified.IdentifiedModel`."""
        from .model import cached_model
        from .identified import IdentifiedModel

        d = self.result_.to_dict()
        return IdentifiedModel(cached_model(self.device).device, d["params"], d["method"], d["treatment"])

    def _chunks(self, model, path, torques=True):
        """The treated input stream: Parquet batches (prefetched), stale rows dropped and re-timed when the
        log needs it, known torques subtracted."""
        chunks = prefetch(iter_parquet_chunks(model, path, self.chunk_rows,
                                              torques=torques or self._retime is not None,
                                              velocities=self._vel_cols))
        if self._retime is not None:
            chunks = retime_chunks(chunks, self._rate, *self._retime)
        if not torques:
            return chunks
        return subtract_known(model, chunks)

    def fit(self, path):
        import pyarrow as pa
        import pyarrow.parquet as pq

        from tendyn.io.logs import LogError, read_meta

        from .estimate import VELOCITIES
        from .model import cached_model
        from .result import IdentificationResult

        model = cached_model(self.device)
        if self.velocities not in VELOCITIES:
            raise ValueError(f"velocities must be one of {', '.join(VELOCITIES)} (got {self.velocities!r})")
        meta = read_meta(path)                  # a LogError naming the file, not a KeyError
        try:
            pf = pq.ParquetFile(str(path))
        except (pa.ArrowException, OSError) as exc:
            raise LogError(f"not a readable Parquet file: {exc}", file=str(path)) from None
        # the units of the file's columns (a prismatic joint's in m, N), checked as in memory
        schema = pf.schema_arrow
        missing = [c for c in stream_columns(model) if c not in schema.names]
        if missing:                             # before the speed pass reads the whole file
            raise LogError(f"identification needs {', '.join(missing)}", file=str(path), column=missing[0])
        model.check_units({f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema})
        rate = self._rate = float(meta["rate_hz"])
        vel = None if self.velocities == "differentiate" else model.velocity_columns(schema.names)
        if self.velocities == "logged" and vel is None:
            raise model.no_logged_velocities()
        self._vel_cols = vel
        tr = default_treatment(rate, getattr(model.device, "bandwidth_hz", None), self.cutoff_hz, self.decimate,
                               self.order, self.velocity_threshold, elastic=model.elastic_drives)
        tr = dataclasses.replace(tr, velocities="logged" if vel else "differentiate")
        # stale rows and time stamps (the same re-timing as in memory) counted on the speed pass, which reads
        # q, τ and the logged speeds once: a clean log is read twice in all, a log to re-time three times
        self._retime = None
        scan = StaleScan(prefetch(iter_parquet_chunks(model, path, self.chunk_rows, velocities=vel)), rate)
        if self.velocity_threshold is None:
            peak, _ = accumulate(model, scan, rate, tr, peak_only=True)
        else:
            for _ in scan:
                pass
        n_stale, n, t0, t_last, on_grid = scan.result()
        if n_stale or not on_grid:
            self._retime = (t0, t_last)
            n = int(np.round((t_last - t0) * rate)) + 1
            if self.velocity_threshold is None:     # the speeds of the re-timed log, as in memory
                peak, _ = accumulate(model, self._chunks(model, path, torques=False), rate, tr, peak_only=True)
        tr = dataclasses.replace(tr, stale_dropped=n_stale, retimed=self._retime is not None)
        from tendyn import _core

        n_out = _core.decimated_length(n, parallel_filter_taps(tr.decimate).size, tr.decimate)
        thr = velocity_thresholds(self.velocity_threshold, peak if self.velocity_threshold is None
                                  else np.zeros(model.n_active), elastic=model.elastic_drives)
        tr = dataclasses.replace(tr, velocity_threshold=tuple(float(v) for v in thr))
        (ne_a, ne_b), _ = accumulate(model, self._chunks(model, path), rate, tr, split_at=n_out // 2,
                                     velocity_threshold=thr)
        ne = NormalEquations(*ne_a.B.shape).merge(ne_a).merge(ne_b)   # the whole log, as in memory
        x, se, cond, resid, per = solve_normal(ne, self.method)
        xa, _, _, _, _ = solve_normal(ne_a, self.method)
        rss_b = ne_b.C - 2 * ne_b.B @ xa + np.einsum("i,jik,k->j", xa, ne_b.A, xa)
        cv = {"fit": "first half", "validate": "second half",
              "residual_rel": float(np.sqrt(max(rss_b.sum(), 0.0) / ne_b.C.sum())),
              "per_joint_residual_rel": [float(v) for v in np.sqrt(np.maximum(rss_b, 0) / ne_b.C)],
              "params": [float(v) for v in xa]}
        base = model.base
        self.names_ = list(base.names)
        self.params_, self.stderr_, self.cond_ = x, se, cond
        self.rel_stderr_ = rel_stderr_pct(se, x)
        self.treatment_ = tr
        empty = np.zeros(0)
        self.result_ = IdentificationResult(
            model.device.name, self.method + "+stream", self.names_,
            [base.expression(i, model.standard_names) for i in range(len(base.names))], x, se, cond,
            int(ne.r.sum()), resid, per, tr, empty, empty, empty, np.zeros(0, int), model.active_numbers, cv,
            units=[model.unit(n) for n in self.names_])
        self.result_.flag_pseudo_inertia(model)
        return self
