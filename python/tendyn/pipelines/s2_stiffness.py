"""S2 §V-B on a capstan device: transmission stiffness from blocked-link tests, the bandwidth it gives and the
identification band that follows (claims C31, C32).

Blocked test (S2 §V-B): the links are rigidly blocked, a triangular torque is applied to one motor and the motor
encoder is read. With the links still, the motor turns only on the capstan (cable) spring, and S2 eqs. (13)–(14)

    Γ_m = K dq_m + B dq̇_m + offset = [dq_m  dq̇_m  1] · [K  B  offset]ᵀ

are fitted by least squares to the measured motor torque (current × torque constant) with the statistics of
S2 eqs. (4)–(7) (ERRATA: the squared norm in σ̂²). K, B and the offset are **motor side** ([N·m/rad],
[N·m·s/rad], [N·m]; ERRATA eq. 19). The motor's dry friction makes the torque–angle curve a hysteresis loop
(S2 Fig. 4): it is not in eq. (13), it shows in the residual and leaves K unbiased for a symmetric loop.

Bandwidth (S2 §V-B, "roughly evaluated taking CAD values for the inertia"): with the motors held by their
servo, each link swings on its transmission spring N² K (joint side, ERRATA eq. 19); the lowest natural
frequency over the workspace poses, √(λ_min(A(q)⁻¹ N² K)) / 2π with A the active-coordinate mass matrix of
the device file ("CAD") without the rotors (they sit on the other side of the spring), is the bandwidth.
The identification band is kept a decade below it (S2: 20 Hz → 0.1–2 Hz), where the capstan is rigid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.ident.lsq import least_squares, rel_stderr_pct
from tendyn.ident.treatment import Treatment, butter_zero_phase, central_differences
from tendyn.results import Result, format_table

__all__ = ["CapstanStiffness", "StiffnessFit", "fit_capstan_stiffness", "capstan_bandwidth", "identification_band",
           "BAND_DECADE", "BAND_LOW_HZ"]

BAND_DECADE = 10.0
"""The identification band ends this factor below the transmission bandwidth (S2: 20 Hz → 2 Hz)."""
BAND_LOW_HZ = 0.1
"""Lowest frequency of the identification band [Hz] (S2 §V-B); the exciting trajectories' slowest period is
1 / BAND_LOW_HZ."""


@dataclass(eq=False)
class StiffnessFit(Result):
    """The fit of S2 eq. (14) on one blocked-link log: K [N·m/rad], B [N·m·s/rad], offset [N·m] (motor side),
    their σ and %σ, cond(W), the residual σ̂ [N·m], and the measured loop (dq_m [rad], Γ_m [N·m]) for the
    hysteresis plot (S2 Fig. 4)."""

    drive: int
    K: float
    B: float
    offset: float
    stderr: np.ndarray
    cond: float
    residual_std: float
    n_rows: int
    dq: np.ndarray = field(repr=False)
    torque: np.ndarray = field(repr=False)

    @property
    def rel_stderr_pct(self) -> np.ndarray:
        return rel_stderr_pct(self.stderr, [self.K, self.B, self.offset])

    def hysteresis_width(self) -> float:
        """Median gap [N·m] between the loading and unloading branches at the same motor angle (≈ 2 × the
        motor's dry friction)."""
        up = np.gradient(self.dq) > 0
        if up.sum() < 10 or (~up).sum() < 10:
            return 0.0
        lo, hi = np.percentile(self.dq, [25, 75])
        grid = np.linspace(lo, hi, 21)

        def branch(sel):
            o = np.argsort(self.dq[sel])
            return np.interp(grid, self.dq[sel][o], self.torque[sel][o])

        return float(np.median(branch(up) - branch(~up)))

    def to_dict(self) -> dict:
        p = self.rel_stderr_pct
        return {"drive": self.drive, "K": self.K, "B": self.B, "offset": self.offset,
                "stderr": [float(v) for v in self.stderr], "rel_stderr_pct": float(p[0]),
                "rel_stderr_pct_all": [float(v) for v in p], "cond": self.cond, "residual_std": self.residual_std,
                "n_rows": self.n_rows, "hysteresis_width_Nm": self.hysteresis_width(), "unit_K": "N·m/rad (motor side)"}

    def table(self) -> str:
        p = self.rel_stderr_pct
        rows = [(f"K{self.drive}", f"{self.K:.4g}", "N·m/rad", f"{p[0]:.3g}"),
                (f"B{self.drive}", f"{self.B:.3g}", "N·m·s/rad", f"{p[1]:.3g}"),
                (f"offset{self.drive}", f"{self.offset:.3g}", "N·m", f"{p[2]:.3g}")]
        return format_table(("Parameter", "Value", "Unit", "Relative deviation %"), rows,
                            title=f"blocked link, drive of joint {self.drive}: cond(W) = {self.cond:.3g}")

    reading = ('Torque against angle with the links blocked, with the fitted line whose slope is the capstan '
               'stiffness; the loop width is friction.')

    def _draw(self, ax) -> None:
        ax.plot(self.dq, self.torque, lw=0.6, label="measured")
        g = np.linspace(self.dq.min(), self.dq.max(), 2)
        ax.plot(g, self.K * g + self.offset, "k--", lw=1.0, label=f"K = {self.K:.3f} N·m/rad")
        ax.set_xlabel("motor angle dq_m [rad]")
        ax.set_ylabel("motor torque [N·m]")
        ax.set_title(f"hysteresis cycle, capstan of joint {self.drive} (S2 Fig. 4)")
        ax.legend(loc="best", fontsize=7)


class CapstanStiffness:
    """S2 eq. (14) on blocked-link logs as an estimator (the contract of :class:`tendyn.ident.IDIM`).

    Parameters
    ----------
    motor : int
        1-based motor (column) number.
    drive : int, optional
        Label of the drive (its joint number, default ``motor``).
    cutoff_hz : float
        −3 dB cut-off [Hz] of the zero-phase Butterworth on the encoder before differentiating (dq̇_m); the
        torque is filtered the same way (parallel filtering, so W and Y keep the same phase).

    ``fit(log)`` returns self; learned: ``params_`` (K [N·m/rad], B [N·m·s/rad], offset [N·m], motor side),
    ``stderr_``, ``rel_stderr_`` [%], ``cond_``, ``treatment_`` (:class:`tendyn.ident.treatment.Treatment`:
    the filter, no decimation), ``result_`` (:class:`StiffnessFit`). ``predict(log)`` the motor torque [N·m]
    at the log's samples, ``score(log)`` its relative error [-].
    """

    def __init__(self, motor: int, drive: int | None = None, cutoff_hz: float = 50.0):
        self.motor = motor
        self.drive = drive
        self.cutoff_hz = cutoff_hz

    def _rows(self, log):
        rate = float(log.meta["rate_hz"])
        q = np.asarray(log[f"q_motor_{self.motor}"], float)
        y = np.asarray(log[f"torque_motor_{self.motor}"], float)
        dqf = butter_zero_phase(q - q[0], self.cutoff_hz, rate)
        yf = butter_zero_phase(y, self.cutoff_hz, rate)
        dqd = central_differences(dqf, 1.0 / rate)
        return np.column_stack([dqf, dqd, np.ones_like(dqf)]), yf, y, dqf, rate

    def fit(self, log) -> "CapstanStiffness":
        W, yf, y, dqf, rate = self._rows(log)
        x, se, s2, _ = least_squares(W, yf)
        self.params_, self.stderr_, self.rel_stderr_ = x, se, rel_stderr_pct(se, x)
        self.cond_ = float(np.linalg.cond(W))
        self.treatment_ = Treatment(float(self.cutoff_hz), 4, 1, None, rate, float("nan"), why=(
            "cut-off given (the blocked motor's spring motion)", "no decimation: the rows are the samples"))
        self.result_ = StiffnessFit(drive=self.motor if self.drive is None else self.drive, K=float(x[0]),
                                    B=float(x[1]), offset=float(x[2]), stderr=se, cond=self.cond_,
                                    residual_std=math.sqrt(s2), n_rows=int(y.size), dq=dqf, torque=y)
        return self

    def predict(self, log) -> np.ndarray:
        """Motor torque [N·m] of S2 eq. (13) at the log's samples (filtered encoder)."""
        W, *_ = self._rows(log)
        return W @ self.params_

    def score(self, log) -> float:
        """‖Γ_m − Γ̂_m‖ / ‖Γ_m‖ [-] against the log's filtered torque."""
        W, yf, *_ = self._rows(log)
        return float(np.linalg.norm(yf - W @ self.params_) / max(np.linalg.norm(yf), 1e-300))

    def get_params(self, deep: bool = True) -> dict:
        return {"motor": self.motor, "drive": self.drive, "cutoff_hz": self.cutoff_hz}


def fit_capstan_stiffness(log, motor: int, drive: int | None = None, cutoff_hz: float = 50.0) -> StiffnessFit:
    """Fit S2 eq. (14) to one blocked-link log (links blocked, triangular torque on motor ``motor``): the
    :class:`StiffnessFit` of :class:`CapstanStiffness` (reads only ``time``, ``q_motor_<motor>`` [rad] and
    ``torque_motor_<motor>`` [N·m]); K, B, offset motor side with their statistics (S2 eqs. 4–7, ERRATA eq. 5).
    """
    return CapstanStiffness(motor, drive, cutoff_hz).fit(log).result_


def capstan_bandwidth(device, stiffness_motor, poses=None, n_poses: int = 60, seed: int = 0) -> dict:
    """Lowest natural frequency [Hz] of the links on their transmission springs, motors held.

    Parameters
    ----------
    device : Device or CompiledDevice
        Its mass matrix ("CAD" inertias of the device file) in active coordinates; rotors excluded.
    stiffness_motor : sequence of float
        Transmission stiffness per drive [N·m/rad], motor side (identified K); joint side N² K (ERRATA eq. 19).
    poses : (n, n_active) array, optional
        Active positions [rad] (default: ``n_poses`` uniform inside the active joint limits, seeded).

    Returns
    -------
    dict
        ``bandwidth_hz`` (the minimum over the poses), ``max_hz``, ``pose`` where the minimum is, and
        ``per_drive_rigid_hz``: √(N² K_i / A_ii) / 2π at that pose (the single-axis estimate).
    """
    from tendyn.device import compile_device
    from tendyn.device.closed_loop import active_mass_matrix

    compiled = compile_device(device)
    dev = compiled.device
    L, c = compiled.active_map
    model, data = compiled.pinocchio_model, compiled.pinocchio_data()
    ratio = np.array([d.ratio for d in dev.drives], float)
    from tendyn.device.stiffness import reflected_stiffness

    Kj = np.diag(reflected_stiffness(stiffness_motor, ratio))
    if poses is None:
        from tendyn.sim.experiments import _active_limits

        lo, hi = _active_limits(dev)
        poses = np.random.default_rng(seed).uniform(lo, hi, (n_poses, lo.size))
    freqs, diag = [], []
    for qa in np.atleast_2d(poses):
        A = active_mass_matrix(model, L, c, qa, data)
        lam = np.linalg.eigvals(np.linalg.solve(A, Kj)).real
        freqs.append(math.sqrt(lam.min()) / (2 * math.pi))
        diag.append(np.sqrt(np.diag(Kj) / np.diag(A)) / (2 * math.pi))
    k = int(np.argmin(freqs))
    return {"bandwidth_hz": float(freqs[k]), "max_hz": float(max(freqs)),
            "pose": [float(v) for v in np.atleast_2d(poses)[k]],
            "per_drive_rigid_hz": [float(v) for v in diag[k]]}


def identification_band(bandwidth_hz: float) -> tuple[float, float]:
    """The identification band [Hz]: (BAND_LOW_HZ, bandwidth / BAND_DECADE), S2 §V-B (20 Hz → 0.1–2 Hz)."""
    return BAND_LOW_HZ, float(bandwidth_hz) / BAND_DECADE

