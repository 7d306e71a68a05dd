"""Constant-speed segments ("plateaus") found from a quantised motor encoder alone.

S0 §III-A identifies friction from moves "at constant velocity, to exclude the effect of inertial
forces". A lab log holds the encoder and the measured torque, not necessarily the controller's
reference, so the segments are found from the encoder:

1. the speed is the least-squares slope of the encoder over a sliding window (a quantised encoder
   differentiated sample by sample is useless: one count per several samples at low speed);
2. a sample is *flat* when it moves (|v| above ``min_speed``) and the windowed speed stays within
   ``tol`` (relative) of its neighbours' over one more window — accelerations and PID transients fail;
3. contiguous flat runs are trimmed by half a window plus ``trim_s`` at both ends (the window blends
   the ramps in), split where their speed drifts by more than ``tol``, and the pieces kept when they
   last at least ``min_duration_s`` and a quarter of the longest piece of their run (a short piece
   beside a long one is a controller transient);
4. each kept plateau's speed is the least-squares slope of the encoder over the whole plateau.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendyn.protocols import PLATEAU


@dataclass(frozen=True)
class Plateau:
    """One constant-speed segment: samples ``start:stop`` of the log.

    speed [rad/s] : least-squares slope of the encoder over the segment (signed)
    spread [rad/s] : standard deviation of the windowed speed inside it
    """

    start: int
    stop: int
    speed: float
    spread: float

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)

    @property
    def size(self) -> int:
        return self.stop - self.start

    def to_dict(self) -> dict:
        return {"start": self.start, "stop": self.stop, "speed": self.speed, "spread": self.spread}


def windowed_slope(t, q, window: int) -> np.ndarray:
    """Least-squares slope dq/dt over a centred window of ``window`` samples (odd, ≥ 3) [unit/s].

    Computed with running sums (O(n)); the ends use the nearest full window. On a quantised signal
    the slope over N samples has an error of about one count / (N dt √(N/12)), far below the count
    per sample of a finite difference.
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    n = t.size
    w = int(window) | 1
    if w < 3:
        raise ValueError(f"window must be at least 3 samples (got {window})")
    if n < w:
        return np.full(n, (q[-1] - q[0]) / (t[-1] - t[0]) if n > 1 else 0.0)
    t0 = t - t[0]
    q0 = q - q[0]
    c = lambda x: np.concatenate([[0.0], np.cumsum(x)])   # noqa: E731
    St, Sq, Stt, Stq = c(t0), c(q0), c(t0 * t0), c(t0 * q0)
    lo = np.arange(n - w + 1)
    hi = lo + w
    st, sq = St[hi] - St[lo], Sq[hi] - Sq[lo]
    stt, stq = Stt[hi] - Stt[lo], Stq[hi] - Stq[lo]
    slope = (w * stq - st * sq) / (w * stt - st * st)
    half = w // 2
    out = np.empty(n)
    out[half:half + slope.size] = slope
    out[:half] = slope[0]
    out[half + slope.size:] = slope[-1]
    return out


def _ls_slope(t, q) -> float:
    tc = t - t.mean()
    return float(np.dot(tc, q - q.mean()) / np.dot(tc, tc))


def find_plateaus(t, q, *, window_s: float = PLATEAU["window_s"], tol: float = PLATEAU["tol"],
                  min_speed: float = PLATEAU["min_speed"], min_duration_s: float = PLATEAU["min_duration_s"],
                  trim_s: float = PLATEAU["trim_s"]) -> list[Plateau]:
    """Constant-speed segments of an encoder signal.

    Parameters
    ----------
    t : (n,) sample times [s], strictly increasing
    q : (n,) encoder position [rad] (quantised is fine)
    window_s : length of the least-squares slope window [s]
    tol : relative speed tolerance of a plateau [-] (with an absolute floor of ``0.1 * min_speed``)
    min_speed : speeds below this are "not moving" [rad/s]
    min_duration_s : shortest plateau kept, after trimming [s]
    trim_s : extra time dropped at both ends of a plateau (controller transient) [s]

    Returns
    -------
    list of :class:`Plateau`, in time order.
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if t.size < 3:
        return []
    dt = float(np.median(np.diff(t)))
    w = max(3, int(round(window_s / dt)) | 1)
    v = windowed_slope(t, q, w)
    floor = 0.1 * min_speed
    # flat: the speed one window earlier and later agrees with the speed here
    vb = np.concatenate([np.full(w, np.nan), v[:-w]])
    va = np.concatenate([v[w:], np.full(w, np.nan)])
    band = tol * np.abs(v) + floor
    with np.errstate(invalid="ignore"):
        flat = (np.abs(v) > min_speed) & (np.abs(vb - v) <= band) & (np.abs(va - v) <= band)
    out: list[Plateau] = []
    trim = w // 2 + int(round(trim_s / dt))
    min_len = max(3, int(round(min_duration_s / dt)))
    for a, b in _runs(flat):
        a, b = a + trim, b - trim          # the run's ends are where the window blends ramps in
        if b - a < min_len:
            continue
        pieces = [(a2, b2) for a2, b2 in _split(v, a, b, tol, floor) if b2 - a2 >= min_len]
        if not pieces:
            continue
        longest = max(b2 - a2 for a2, b2 in pieces)
        for a2, b2 in pieces:
            if b2 - a2 < 0.25 * longest:   # a short piece beside a long one is a transient
                continue
            seg = slice(a2, b2)
            out.append(Plateau(int(a2), int(b2), _ls_slope(t[seg], q[seg]), float(np.std(v[seg]))))
    return out


def _runs(mask):
    """(start, stop) of each run of True."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _split(v, a, b, tol, floor):
    """Split [a, b) where the speed leaves the band around the running median of the segment."""
    segs = []
    start = a
    while start < b:
        ref = v[start]
        stop = start + 1
        # grow while inside the band around the median of what is already in
        k = 0
        while stop < b:
            if k % 64 == 0:
                ref = float(np.median(v[start:stop]))
            if abs(v[stop] - ref) > tol * abs(ref) + floor:
                break
            stop += 1
            k += 1
        segs.append((start, stop))
        start = stop
    return segs
