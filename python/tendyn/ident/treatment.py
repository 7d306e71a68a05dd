"""Data treatment of the inverse-dynamic-model identification, as Gautier does it.

1. Positions: zero-phase Butterworth low-pass (forward-backward); the cut-off is given in Hz and is the
   −3 dB point of the *zero-phase* response (the design frequency is corrected for the squared magnitude).
2. Velocities and accelerations: central differences of the filtered positions.
3. Parallel filtering and decimation: the torques Y and every column of the observation matrix W go through
   the same symmetric FIR low-pass and keep every K-th sample, windows centred on the same input samples
   (the C++ core does it for W while it builds it, so the full-rate W is never held).
4. Optionally, samples where a joint's velocity is near zero are removed from that joint's rows (the Coulomb
   term sign(q̇) is ill-defined there).

Real logs as they come (before step 1): a row that repeats the previous one exactly (positions and torques
identical: the logger wrote a sample the sensors had not refreshed) is *stale*; stale rows are dropped and the
remaining samples are re-timed onto the uniform grid of the log's rate by linear interpolation on their own time
stamps (so the derivatives are taken on the true times, not on row indices); a log whose time stamps stray from
the uniform grid is re-timed the same way. Logged velocities (``qd_motor_<i>``, ``qd_joint_<j>``), when used,
replace the differentiated positions: they are filtered like the positions and differentiated once for q̈.

Defaults (Gautier): position cut-off 5 × the device's dynamic bandwidth (below a tenth of the rate);
decimation K so that the decimated rate is ≈ 10 × the bandwidth, parallel-filter cut-off 0.8 × the decimated
Nyquist frequency.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from tendyn.ident.filters import butter_lowpass_sos, firwin_lowpass, sosfiltfilt

__all__ = ["Treatment", "Block", "AlignmentError", "butter_zero_phase", "parallel_filter_taps",
           "central_differences", "stack_blocks", "default_treatment", "drop_stale", "DEFAULT_VELOCITY_FRACTION",
           "velocity_thresholds", "above_threshold", "ELASTIC_VELOCITY_FRACTION",
           "PRESETS", "Preset", "preset_treatment", "zero_phase_cutoff_of_design"]

DEFAULT_BANDWIDTH_HZ = 10.0

DEFAULT_VELOCITY_FRACTION = 0.0025
"""Default velocity threshold (the one place it is written): a joint's samples slower than this fraction of
its peak |q̇| in the log are dropped from its rows. 0.25 %, chosen on the real logs and the twins
(docs/realdata.md, "The default velocity threshold"): EMPS every value within 1 % of Janot's only below 0.5 %,
the MTM 7/7 at or below WPI from 0.25 % to 2 %, the TX40 halves 5 % worse than at 2 %, the twins' tests unchanged."""

ELASTIC_VELOCITY_FRACTION = 0.10
"""Default velocity threshold on a device whose capstan ``[[drives]]`` are elastic (finite cable stiffness): 10 %
of each joint's peak |q̇|. There the dry friction sits at the motor, behind the cable spring: at each reversal the
motor sticks while the spring winds up by 2 C_m / K (S2 Fig. 4), so the joint-side friction passes through zero
over a band of speeds, not as F_C sign(q̇); least squares fits that ramp with a larger viscous slope and a smaller
Coulomb term. Measured on generated parallelogram arms 0-4 (the band exciting design, 20 s): at 0.25 % FV
+32 … +406 % (σ 13-30 %, no warning) and FS −2 … −4 %; at 10 % FV −18 … +60 % (σ 7-33 %) and FS within 0.3 %.
On the twin's default fast design for such drives (120 s, design_fast) 10 % is 0.30-0.38 rad/s: FS within
0.14 %, FV within 7.4 % on arms 0-2 (docs/device-file.md, "Identification by default")."""

def velocity_thresholds(rule, peaks, elastic: bool = False) -> np.ndarray:
    """Per-joint velocity threshold [rad/s] (the one rule, in memory and ``--stream``): ``rule`` None gives the
    :data:`DEFAULT_VELOCITY_FRACTION` of each joint's peak |q̇| ``peaks`` [rad/s] in the log
    (:data:`ELASTIC_VELOCITY_FRACTION` when ``elastic``: a device with elastic capstan drives); a tuple, one value
    per joint; a number, the same for every joint (0 keeps every row)."""
    peaks = np.asarray(peaks, float)
    if rule is None:
        return (ELASTIC_VELOCITY_FRACTION if elastic else DEFAULT_VELOCITY_FRACTION) * peaks
    if isinstance(rule, tuple):
        return np.asarray(rule, float)
    return np.full(peaks.shape, float(rule))


def above_threshold(qd, threshold) -> np.ndarray:
    """Which samples a velocity threshold keeps: |q̇| ≥ threshold (both [rad/s], broadcast), the rows of W a
    joint contributes (S2 §V-C: slow rows, where the dry friction sticks, are left out)."""
    return np.abs(np.asarray(qd, float)) >= threshold


FIGAROH_DECIMATE = (10, 10)
"""FIGAROH's TX40 script decimates the torques and every regressor column by scipy.signal.decimate(q=10,
zero_phase=True) twice (100 in all)."""

FIGAROH_LAST_ACCELERATION = False
"""FIGAROH's calculate_first_second_order_differentiation loops over the first nq − 1 joints only: the last
joint's acceleration stays zero (reproduced; True computes it, to measure what it changes)."""

FIGAROH_BLOCK_SHIFT = True
"""FIGAROH's TX40 script slices joint i's regressor block at i × (n − 40) of a matrix whose blocks have n − 42
rows: joint i's rows are 2i samples ahead of its torques (reproduced; False aligns them, to measure it)."""

JANOT_FIRST_ROW = 50
"""Janot's script keeps the rows 50…N (1-based) of the full-rate observation matrix before decimating."""

RETIME_TOLERANCE = 0.01
"""Time stamps further than this fraction of the sampling interval from the uniform grid are re-timed."""


class AlignmentError(ValueError):
    """The row blocks of Y and W do not hold the same samples."""


def butter_zero_phase(x, cutoff_hz: float, rate_hz: float, order: int = 4, axis: int = 0) -> np.ndarray:
    """Zero-phase Butterworth low-pass whose forward-backward response is −3 dB at ``cutoff_hz``.

    ``filtfilt`` squares the magnitude; the single-pass design frequency f_d is chosen so that
    |H(f_c)|² = 1/√2, i.e. (with the bilinear transform's pre-warping)
    tan(π f_d / f_s) = tan(π f_c / f_s) / (√2 − 1)^(1/(2 order)).
    """
    if not 0 < cutoff_hz < rate_hz / 2:
        raise ValueError(f"cut-off {cutoff_hz} Hz must be in (0, {rate_hz / 2}) Hz (half the rate)")
    warped = np.tan(np.pi * cutoff_hz / rate_hz) / (np.sqrt(2.0) - 1.0) ** (1.0 / (2 * order))
    fd = np.arctan(warped) * rate_hz / np.pi
    fd = min(fd, 0.499 * rate_hz)
    sos = butter_lowpass_sos(order, fd, rate_hz)                 # scipy.signal's design, without its import
    return sosfiltfilt(sos, np.asarray(x, float), axis=axis)


def central_differences(x, dt: float) -> np.ndarray:
    """dx/dt by central differences (one-sided at the two ends), along axis 0."""
    return np.gradient(np.asarray(x, float), dt, axis=0)


def parallel_filter_taps(K: int) -> np.ndarray:
    """The symmetric FIR of the parallel filter for decimation K: 10 K + 1 taps (Hamming), cut-off
    0.8 × the decimated Nyquist frequency, unit DC gain. K = 1: no filter ([1])."""
    if K <= 1:
        return np.ones(1)
    taps = firwin_lowpass(10 * K + 1, 0.8 / K)
    return taps / taps.sum()


@dataclass(frozen=True)
class Treatment:
    """The treatment settings: position cut-off [Hz], Butterworth order, decimation K, velocity threshold
    [rad/s] below which a joint's rows are dropped (0: none), and where the defaults came from; what was done
    to the samples: ``velocities`` ("differentiate" or "logged"), ``stale_dropped`` (stale rows removed),
    ``retimed`` (samples interpolated onto the uniform grid)."""

    cutoff_hz: float
    order: int
    decimate: int
    velocity_threshold: float | tuple | None
    rate_hz: float
    bandwidth_hz: float
    velocities: str = "differentiate"
    stale_dropped: int = 0
    retimed: bool = False
    why: tuple = ()
    """Where each setting came from, one phrase each (given, or which of Gautier's defaults and from what)."""
    filter_torques: bool = False
    """The torques go through the positions' Butterworth too (a peer's treatment: WPI), besides the parallel
    filter."""
    trim: int = 0
    """Samples cut at each end of every log after filtering (the filters' edge transients)."""
    weighting: str | None = None
    """``wls`` weights: None (tendyn: 1/σ of each joint's OLS residual) or ``"range"`` (1 / (max − min) of each
    row block's filtered torque, WPI)."""
    space: str = "joint"
    """Space of the fitted rows: ``"joint"`` (τ = Gᵀ y) or ``"motor"`` (y, the logged torques; needs every
    sample of every joint: velocity threshold 0)."""
    keep_stale: bool = False
    """Keep the stale rows (repeats of the previous sample) as they are, not re-timed (a peer that used them)."""
    preset: str = "tendyn"
    """The preset these settings came from (:data:`PRESETS`): "tendyn" (tendyn's defaults and the options given)
    or a peer's published treatment reproduced."""

    @property
    def parallel_cutoff_hz(self) -> float:
        return 0.8 * self.rate_hz / (2 * self.decimate) if self.decimate > 1 else self.rate_hz / 2

    def filter_positions(self, q) -> np.ndarray:
        """The positions (or logged velocities) low-passed as this treatment does: tendyn's zero-phase
        Butterworth −3 dB at :attr:`cutoff_hz`, or (janot) MATLAB's ``filtfilt(butter(order, Wn))``."""
        if self.preset == "janot":
            from tendyn.ident.filters import matlab_butter_filtfilt

            return matlab_butter_filtfilt(q, self.cutoff_hz, self.rate_hz, self.order)
        return butter_zero_phase(q, self.cutoff_hz, self.rate_hz, self.order)

    @property
    def warnings(self) -> list[str]:
        """The settings that break Gautier's rule: the parallel filter must cut below the position filter, or the
        torques keep a band the observation matrix (built from the filtered positions) has lost — a bias of the
        inertias, not noise (measured: a generated 1-joint arm at cut-off 20 Hz, decimation 10 at 1 kHz: ZZ1R
        +3.3 %, 5.7σ; decimation 20 (both at 20 Hz): +0.86 %; decimation 25: +0.27 %)."""
        if self.parallel_cutoff_hz <= self.cutoff_hz:
            return []
        return [f"the parallel filter passes the torques up to {self.parallel_cutoff_hz:g} Hz, above the positions' "
                f"cut-off {self.cutoff_hz:g} Hz: the band between has no counterpart in the observation matrix and "
                f"biases the inertias; decimate by {int(np.ceil(0.5 * self.rate_hz / self.cutoff_hz))} or more (the "
                f"parallel filter at 0.8 x the cut-off, as the defaults), or raise the cut-off (Gautier: the parallel "
                f"filter cuts below the position filter)"]

    def _vt_text(self) -> str:
        v = self.velocity_threshold
        if v is None:
            return f"{100 * DEFAULT_VELOCITY_FRACTION:g} % of each joint's peak speed"
        if isinstance(v, tuple):
            return "(" + ", ".join(f"{x:.3g}" for x in v) + ") rad/s per joint (m/s at a prismatic joint)"
        return f"{v:g} rad/s"

    def _samples_text(self) -> str:
        vel = ("logged velocities (filtered like the positions), accelerations by central differences"
               if self.velocities == "logged" else "velocities and accelerations by central differences")
        stale = f"; {self.stale_dropped} stale samples dropped (repeats of the previous row)" \
            if self.stale_dropped else "; no stale samples"
        return vel + stale + ("; re-timed onto the uniform grid" if self.retimed else "")

    def describe(self) -> str:
        if self.preset == "figaroh":
            return (f"treatment figaroh ({PRESETS['figaroh'].source}): Butterworth order {self.order} designed at "
                    f"{self.cutoff_hz:g} Hz (scipy butter + filtfilt); {5 * self.order} samples cut at each end; "
                    f"decimation {self.decimate} ({self.rate_hz:g} Hz -> {self.rate_hz / self.decimate:g} Hz); "
                    f"velocity threshold {self._vt_text()}" + (f"; why: {'; '.join(self.why)}" if self.why else ""))
        if self.preset == "janot":
            return (f"treatment janot ({PRESETS['janot'].source}): Butterworth order {self.order} at {self.cutoff_hz:g} "
                    f"Hz (MATLAB butter + filtfilt); {self._samples_text()}; rows {JANOT_FIRST_ROW} on; MATLAB "
                    f"decimate by {self.decimate} ({self.rate_hz:g} Hz -> {self.rate_hz / self.decimate:g} Hz); "
                    f"velocity threshold {self._vt_text()}" + (f"; why: {'; '.join(self.why)}" if self.why else ""))
        extra = "".join([f"; preset {self.preset}" if self.preset != "tendyn" else "",
                         "; torques through the same Butterworth" if self.filter_torques else "",
                         f"; {self.trim} samples cut at each end" if self.trim else "",
                         f"; weights 1/range of each {self.space} torque" if self.weighting == "range" else "",
                         "; fitted in motor space" if self.space == "motor" else ""])
        return (f"treatment: Butterworth order {self.order} zero-phase on positions, -3 dB at {self.cutoff_hz:g} Hz; "
                f"{self._samples_text()}; parallel filter {10 * self.decimate + 1 if self.decimate > 1 else 1} taps, "
                f"cut-off {self.parallel_cutoff_hz:g} Hz, decimation {self.decimate} "
                f"({self.rate_hz:g} Hz -> {self.rate_hz / self.decimate:g} Hz); velocity threshold "
                f"{self._vt_text()} (log rate {self.rate_hz:g} Hz, device bandwidth "
                f"{self.bandwidth_hz:g} Hz)" + extra + (f"; why: {'; '.join(self.why)}" if self.why else ""))

    def to_dict(self) -> dict:
        v = self.velocity_threshold
        return {"cutoff_hz": self.cutoff_hz, "order": self.order, "decimate": self.decimate,
                "velocity_threshold": list(v) if isinstance(v, tuple) else v, "rate_hz": self.rate_hz,
                "bandwidth_hz": self.bandwidth_hz, "parallel_cutoff_hz": self.parallel_cutoff_hz,
                "velocities": self.velocities, "stale_dropped": self.stale_dropped, "retimed": self.retimed,
                "why": list(self.why), "filter_torques": self.filter_torques, "trim": self.trim,
                "weighting": self.weighting, "space": self.space, "keep_stale": self.keep_stale,
                "preset": self.preset}


def default_treatment(rate_hz: float, bandwidth_hz: float | None, cutoff_hz=None, decimate=None, order: int = 4,
                      velocity_threshold: float | None = 0.0, elastic: bool = False) -> Treatment:
    """Gautier's defaults from the log's rate and the device's dynamic bandwidth (explicit values win); each
    setting's origin goes into :attr:`Treatment.why` (``elastic``: the device's capstan drives are elastic, the
    default velocity threshold is :data:`ELASTIC_VELOCITY_FRACTION`, :func:`velocity_thresholds`). A peer's
    settings: :func:`preset_treatment`."""
    bw = float(bandwidth_hz or DEFAULT_BANDWIDTH_HZ)
    why = [] if bandwidth_hz else [f"the device file gives no bandwidth_hz, {bw:g} Hz assumed"]
    if cutoff_hz is None:
        cutoff_hz = min(5.0 * bw, rate_hz / 10.0)
        why.append(f"cut-off 5 x the bandwidth ({5.0 * bw:g} Hz), above the motion and below the noise"
                   if 5.0 * bw <= rate_hz / 10.0 else
                   f"cut-off a tenth of the rate ({rate_hz / 10.0:g} Hz; 5 x the bandwidth would be above it)")
    else:
        why.append("cut-off given")
    if decimate is None:
        decimate = max(1, int(rate_hz // (10.0 * bw)))
        why.append(f"decimation to about 10 x the bandwidth ({rate_hz / decimate:g} Hz)")
    else:
        why.append("decimation given")
    if velocity_threshold is None and elastic:
        why.append(f"velocity threshold {100 * ELASTIC_VELOCITY_FRACTION:g} % of each joint's peak speed (elastic "
                   "capstan drives: at each reversal the motor sticks behind the cable spring)")
    elif velocity_threshold is None:
        why.append(f"velocity threshold {100 * DEFAULT_VELOCITY_FRACTION:g} % of each joint's peak speed "
                   "(the sign of the Coulomb term is undefined near rest)")
    else:
        why.append("velocity threshold given")
    vt = None if velocity_threshold is None else (tuple(float(v) for v in velocity_threshold)
                                                  if np.ndim(velocity_threshold) else float(velocity_threshold))
    return Treatment(float(cutoff_hz), int(order), int(decimate), vt, float(rate_hz), bw, why=tuple(why))


def zero_phase_cutoff_of_design(design_hz: float, rate_hz: float, order: int) -> float:
    """The −3 dB frequency [Hz] of the forward-backward response of a Butterworth whose single-pass design
    frequency is ``design_hz`` (scipy's ``butter(order, design_hz / (rate_hz / 2))``, as peers call it): the inverse
    of the correction in :func:`butter_zero_phase`, so that ``butter_zero_phase(x, this, rate, order)`` is that
    filter."""
    t = np.tan(np.pi * design_hz / rate_hz) * (np.sqrt(2.0) - 1.0) ** (1.0 / (2 * order))
    return float(np.arctan(t) * rate_hz / np.pi)


def _wpi(rate_hz: float, bandwidth_hz) -> dict:
    """WPI's dVRK identification (WPI-AIM/dvrk_dynamics_identification, main_mtm.ipynb cells 49–91 and
    identification/data_processing.py): positions, logged velocities and torques through one 6th-order Butterworth
    filtfilt of normalised frequency Wn = 2π f_c / rate (a fraction of Nyquist) with f_c = 3 × 0.1 Hz × 6 = 1.8 Hz
    (their base frequency × Fourier order × 3), i.e. a single-pass design frequency Wn × rate / 2 = 5.65 Hz at
    200 Hz, accelerations by differences of the velocities, no decimation, 200 samples cut at each end, no
    velocity threshold, the stale rows of the log kept as they are (WPI's loader reads every row), the fit in motor space
    weighted by 1 / (max − min) of each motor's filtered torque."""
    design = 1.8 * 2 * np.pi / rate_hz * (rate_hz / 2)        # Wn × Nyquist [Hz]
    return dict(cutoff_hz=zero_phase_cutoff_of_design(design, rate_hz, 6), order=6, decimate=1,
                velocity_threshold=0.0, velocities="logged", filter_torques=True, trim=200, weighting="range",
                space="motor", keep_stale=True)


def _tendyn(rate_hz: float, bandwidth_hz) -> dict:
    """tendyn's own treatment: every setting from :func:`default_treatment` and the options given."""
    return {}


def _janot(rate_hz: float, bandwidth_hz) -> dict:
    """Janot, Gautier & Brunot's Script_IDIM_LS.m (EMPS): cut-off and decimation rate both 5 × the bandwidth,
    no velocity threshold; the MATLAB filters and the first row are :func:`_treat_janot`'s."""
    bw = float(bandwidth_hz or DEFAULT_BANDWIDTH_HZ)
    return dict(cutoff_hz=5.0 * bw, decimate=max(1, int(round(rate_hz / (5.0 * bw)))), velocity_threshold=0.0)


def _figaroh(rate_hz: float, bandwidth_hz) -> dict:
    """FIGAROH's examples/staubli_TX40/identification.py: the config's Butterworth cut-off (100 Hz for the TX40,
    i.e. 10 × its 10 Hz bandwidth) read as Wn = ts · f_c / 2, a single-pass design at f_c / 4 (the cut-off given
    is that design frequency [Hz]), order 4, decimation by 10 twice. The per-joint velocity thresholds are the
    robot's config (dq_lim_def): give them (velocity_threshold); the rest is :func:`_treat_figaroh`'s."""
    bw = float(bandwidth_hz or DEFAULT_BANDWIDTH_HZ)
    return dict(cutoff_hz=10.0 * bw / 4.0, order=4, decimate=int(np.prod(FIGAROH_DECIMATE)))


@dataclass(frozen=True)
class Preset:
    """A data treatment ``tendyn identify --treatment NAME`` applies: where it comes from (one phrase, printed in
    the option's help and the treatment's description) and the :class:`Treatment` fields it sets for a log at
    ``rate_hz`` [Hz] of a device of dynamic bandwidth ``bandwidth_hz`` [Hz] (None: not in the device file). A
    field the preset does not set comes from :func:`default_treatment` and the options given; ``cutoff_hz``,
    ``decimate`` and ``velocity_threshold`` given as options win over the preset's."""
    source: str
    fields: object


PRESETS = {
    "tendyn": Preset("tendyn's own (Gautier's rules): zero-phase Butterworth -3 dB at 5 x the bandwidth, central "
                     "differences, parallel FIR filter + decimation to about 10 x the bandwidth, the default "
                     "velocity threshold", _tendyn),
    "janot": Preset("Janot, Gautier & Brunot's Script_IDIM_LS.m (EMPS, 2019): MATLAB butter(4, 5 x bandwidth) "
                    "through filtfilt (single-pass design: -6 dB there), central differences, rows 50 on, every "
                    "column and the torque through MATLAB's decimate (Chebyshev I order 8, filtfilt) by rate / "
                    "(5 x bandwidth), no velocity threshold", _janot),
    "wpi": Preset("WPI's dVRK notebook (main_mtm.ipynb): order-6 Butterworth (Wn = 2 pi 1.8 Hz / rate) on "
                  "positions, logged velocities and torques, 200 samples cut at each end, no threshold, stale rows "
                  "kept, fit in motor space weighted by 1 / range of each motor's torque", _wpi),
    "figaroh": Preset("FIGAROH's Staubli TX40 script (identification.py): scipy butter(4) filtfilt at the "
                      "config's cut-off read as Wn = ts fc / 2 (a design at 2.5 x the bandwidth), 20 samples cut "
                      "at each end, forward differences then np.gradient (the last joint's acceleration left at "
                      "zero), joint blocks sliced as the script does, scipy decimate(10) twice on torques and "
                      "columns, the given per-joint velocity thresholds", _figaroh),
}
"""The one table of data treatments: ``--treatment NAME`` (its domain, tendyn.commands.args), ``IDIM(treatment=)``
and :attr:`Treatment.preset` take their names from it; docs/realdata.md describes each with what it reproduces."""


def preset_treatment(name: str, rate_hz: float, bandwidth_hz=None, cutoff_hz=None, decimate=None, order: int = 4,
                     velocity_threshold=None, elastic: bool = False) -> Treatment:
    """The :class:`Treatment` of preset ``name`` (:data:`PRESETS`) for a log at ``rate_hz`` [Hz]; ``cutoff_hz``
    [Hz], ``decimate`` and ``velocity_threshold`` [rad/s] given (not None) win over the preset's, ``order`` is the
    preset's when it sets one. ValueError naming the presets for an unknown name."""
    if name not in PRESETS:
        raise ValueError(f"unknown treatment preset {name!r} (presets: {', '.join(PRESETS)})")
    fields = dict(PRESETS[name].fields(float(rate_hz), bandwidth_hz))
    given = {"cutoff_hz": cutoff_hz, "decimate": decimate, "velocity_threshold": velocity_threshold}
    from_preset = [k for k, v in given.items() if v is None and k in fields]
    for k, v in given.items():
        if k not in from_preset:
            fields[k] = v
    order = fields.pop("order", order)
    tr = default_treatment(rate_hz, bandwidth_hz, fields.pop("cutoff_hz"), fields.pop("decimate"), order,
                           fields.pop("velocity_threshold"), elastic=elastic)
    if name == "tendyn":
        return tr
    said = {"cutoff_hz": "cut-off given", "decimate": "decimation given",
            "velocity_threshold": "velocity threshold given"}
    why = (f"preset {name}" + (f" ({', '.join(k for k in from_preset)})" if from_preset else ""),) + tuple(
        w for w in tr.why if w not in {said[k] for k in from_preset})
    velocities = fields.pop("velocities", tr.velocities)
    return dataclasses.replace(tr, velocities=velocities, preset=name, why=why, **fields)


def drop_stale(time, rate_hz: float, q, tau, qd=None):
    """Drop the stale rows of a log's joint signals and re-time the rest onto the uniform grid.

    A row is stale when its positions q and torques τ all equal the previous row's (bit for bit). The kept
    samples are interpolated linearly, on their own time stamps [s], onto t₀ + k / rate (same span); a log
    without stale rows whose stamps are within :data:`RETIME_TOLERANCE` of that grid is returned unchanged.

    Returns (time, q, tau, qd, n_stale, retimed).
    """
    time = np.asarray(time, float)
    q, tau = np.asarray(q, float), np.asarray(tau, float)
    stale = np.zeros(time.size, bool)
    if time.size > 1:
        stale[1:] = np.all(q[1:] == q[:-1], axis=1) & np.all(tau[1:] == tau[:-1], axis=1)
    n_stale = int(stale.sum())
    dt = 1.0 / rate_hz
    grid = time[0] + dt * np.arange(int(np.round((time[-1] - time[0]) * rate_hz)) + 1)
    on_grid = grid.size == time.size and np.max(np.abs(time - grid)) <= RETIME_TOLERANCE * dt
    if n_stale == 0 and on_grid:
        return time, q, tau, qd, 0, False
    keep = ~stale
    tk = time[keep]

    def interp(x):
        return None if x is None else np.column_stack([np.interp(grid, tk, x[keep, j]) for j in range(x.shape[1])])

    return grid, interp(q), interp(tau), interp(qd), n_stale, True


@dataclass
class Block:
    """The rows of one active joint: sample times [s], torques y [N·m] and regressor rows W."""

    time: np.ndarray
    y: np.ndarray
    W: np.ndarray
    velocity: np.ndarray | None = None


def stack_blocks(blocks: list[Block], tol: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stack joint blocks into Y, W (joint-major) after checking they hold the same samples.

    Every block must have the same sample times (to a tenth of the sampling interval): a Y block shifted by
    one sample against W, or against the other joints, raises :class:`AlignmentError`.
    Returns (Y, W, joint index of every row).
    """
    ref = blocks[0].time
    dt = float(np.median(np.diff(ref))) if ref.size > 1 else 1.0
    tol = 0.1 * dt if tol is None else tol
    for j, b in enumerate(blocks):
        if b.time.shape != ref.shape or b.y.shape[0] != b.time.size or b.W.shape[0] != b.time.size:
            raise AlignmentError(f"joint block {j + 1}: {b.time.size} sample times, {b.y.shape[0]} torques, "
                                 f"{b.W.shape[0]} regressor rows, joint 1 has {ref.size}")
        off = np.max(np.abs(b.time - ref)) if ref.size else 0.0
        if off > tol:
            raise AlignmentError(f"joint block {j + 1} is shifted by {off / dt:.3g} samples against joint 1")
    Y = np.concatenate([b.y for b in blocks])
    W = np.vstack([b.W for b in blocks])
    rows = np.concatenate([np.full(b.y.size, j) for j, b in enumerate(blocks)])
    return Y, W, rows


def treat(model, time, q, tau, treatment: Treatment, columns=None, qd=None):
    """Filter, differentiate, build W in the core with the parallel filter and decimation, decimate τ the
    same way, and return the joint blocks (near-zero-velocity samples not yet removed).

    ``qd``: logged joint velocities [rad/s] (filtered like q, differentiated for q̈) instead of dq/dt."""
    from tendyn import _core

    if treatment.preset == "janot":
        return _treat_janot(model, time, q, tau, treatment, columns, qd)
    if treatment.preset == "figaroh":
        return _treat_figaroh(model, time, q, tau, treatment, columns)
    dt = 1.0 / treatment.rate_hz
    qf = butter_zero_phase(q, treatment.cutoff_hz, treatment.rate_hz, treatment.order)
    if treatment.filter_torques:
        tau = butter_zero_phase(tau, treatment.cutoff_hz, treatment.rate_hz, treatment.order)
    if qd is None:
        qd = central_differences(qf, dt)
    else:
        qd = butter_zero_phase(qd, treatment.cutoff_hz, treatment.rate_hz, treatment.order)
    qdd = central_differences(qd, dt)
    taps = parallel_filter_taps(treatment.decimate)
    K = treatment.decimate
    W = model.regressor(qf, qd, qdd, taps, K, columns)
    signals = np.column_stack([np.asarray(time, float), tau, qd])
    dec = _core.fir_decimate(taps, K, np.ascontiguousarray(signals))
    # sample times of W's rows: windows centred on input h + kK (independent route from the FIR of `time`)
    h = (taps.size - 1) // 2
    n_out = dec.shape[0]
    t_w = np.asarray(time, float)[h + K * np.arange(n_out)]
    na = q.shape[1]
    blocks = []
    for j in range(na):
        blocks.append(Block(time=dec[:, 0], y=dec[:, 1 + j], W=W[j * n_out:(j + 1) * n_out],
                            velocity=dec[:, 1 + na + j]))
    # W's own times must match the decimated time column
    if n_out and np.max(np.abs(dec[:, 0] - t_w)) > 0.1 * dt * max(1, 1):
        raise AlignmentError("the decimated torques and the regressor rows are not centred on the same samples")
    m = treatment.trim
    if m:
        if n_out <= 2 * m:
            raise ValueError(f"the log has {n_out} samples, the treatment cuts {m} at each end")
        blocks = [Block(time=b.time[m:-m], y=b.y[m:-m], W=b.W[m:-m], velocity=b.velocity[m:-m]) for b in blocks]
    return blocks


def _treat_janot(model, time, q, tau, treatment: Treatment, columns=None, qd=None):
    """Janot's Script_IDIM_LS.m (PROVENANCE of the EMPS data): positions through MATLAB's filtfilt(butter),
    central differences, the full-rate observation matrix from row 50 on, every column and the torques through
    MATLAB's decimate. Returns the joint blocks as :func:`treat` does."""
    from tendyn.ident.filters import matlab_decimate, matlab_decimate_index

    dt = 1.0 / treatment.rate_hz
    qf = treatment.filter_positions(q)
    qd = central_differences(qf, dt) if qd is None else treatment.filter_positions(qd)
    qdd = central_differences(qd, dt)
    W = model.regressor(qf, qd, qdd, (1.0,), 1, columns)          # (na * n, p), joint-major, full rate
    n, na = q.shape
    s0 = JANOT_FIRST_ROW - 1
    K = treatment.decimate
    keep = s0 + matlab_decimate_index(n - s0, K)
    t_out = np.asarray(time, float)[keep]
    blocks = []
    for j in range(na):
        Wj = matlab_decimate(W[j * n + s0:(j + 1) * n], K)
        yj = matlab_decimate(np.asarray(tau, float)[s0:, j], K)
        vj = matlab_decimate(qd[s0:, j], K)
        blocks.append(Block(time=t_out, y=yj, W=Wj, velocity=vj))
    return blocks


def _treat_figaroh(model, time, q, tau, treatment: Treatment, columns=None):
    """FIGAROH's examples/staubli_TX40/identification.py step by step (snapshot c3b5172): positions through
    scipy's ``filtfilt(butter(order, Wn), padlen=3 (n − 1))`` with Wn = cutoff_hz / (rate / 2), 5 × order
    samples cut at each end; q̇ by forward differences, q̈ = np.gradient(q̇) (the last joint's left at zero:
    :data:`FIGAROH_LAST_ACCELERATION`), the last two rows dropped; the torques cut by the same 5 × order at each
    end; joint i's regressor rows sliced at i × (its torque length) (:data:`FIGAROH_BLOCK_SHIFT`); torques and
    every column through ``scipy.signal.decimate(q=10, zero_phase=True)`` twice. The velocity of each decimated
    row is the joint's decimated FV column, as the script thresholds it. Returns the joint blocks."""
    import scipy.signal as ss

    dt = 1.0 / treatment.rate_hz
    q, tau = np.asarray(q, float), np.asarray(tau, float)
    n, na = q.shape
    b, a = ss.butter(treatment.order, treatment.cutoff_hz / (treatment.rate_hz / 2.0))
    nb = 5 * treatment.order
    qf = ss.filtfilt(b, a, q, axis=0, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))[nb:n - nb]
    qd = np.diff(qf, axis=0) / dt                                     # (n − 2 nb − 1)
    qdd = np.gradient(qd, axis=0, edge_order=1) / dt
    if not FIGAROH_LAST_ACCELERATION:
        qdd[:, -1] = 0.0
    qf, qd, qdd = qf[:-2], qd[:-1], qdd[:-1]                          # N = n − 2 nb − 2 rows
    W = model.regressor(qf, qd, qdd, (1.0,), 1, columns)             # (na N, p), joint-major
    N = qf.shape[0]
    y = tau[nb:n - nb]                                                 # nj = n − 2 nb rows per joint
    nj = y.shape[0]
    names = model.standard_names if columns is None else [model.standard_names[c] for c in columns]
    t = np.asarray(time, float)[nb:n - nb]

    def dec(x):
        for r in FIGAROH_DECIMATE:
            x = ss.decimate(x, r, axis=0, zero_phase=True)
        return x

    blocks = []
    for j, num in enumerate(model.active_numbers):
        start = j * nj if FIGAROH_BLOCK_SHIFT else j * N
        Wj = dec(W[start:start + (nj if FIGAROH_BLOCK_SHIFT else N)])
        yj = dec(y[:, j])
        m = min(len(yj), Wj.shape[0])
        fv = names.index(f"FV{num}")
        tj = t[::int(np.prod(FIGAROH_DECIMATE))][:m]
        blocks.append(Block(time=tj, y=yj[:m], W=Wj[:m], velocity=Wj[:m, fv]))
    m = min(bl.y.size for bl in blocks)
    return [Block(time=bl.time[:m], y=bl.y[:m], W=bl.W[:m], velocity=bl.velocity[:m]) for bl in blocks]
