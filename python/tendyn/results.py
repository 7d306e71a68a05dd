"""Result objects of one shape: ``plot(ax=None)``, ``to_dict()``, ``table()`` (and ``str()`` = the table).

Every result that has a figure derives from :class:`Result`:

* ``plot(ax=None)`` draws into the given axes (or, for a result with several panels, the given sequence of
  axes), or into a new figure, and returns the figure. New figures are :class:`matplotlib.figure.Figure`
  objects made directly, not through pyplot: no backend is needed, none is selected or switched, and no
  pyplot window or figure-manager state is touched. Save one with :func:`tendyn.io.save_png`.
* ``to_dict()`` returns plain JSON-able values (lists, floats, str, dicts).
* ``table()`` returns the text table printed by ``print(result)``, laid out like the papers' tables.

:class:`FrequencyResponse` is the one frequency-response result (stepped and swept sines, on the tendon bench
and on chains, measured or analytic). This module computes nothing; it imports only numpy and matplotlib.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

__all__ = ["FrequencyResponse", "Result", "format_table", "new_figure"]


def new_figure(nrows: int = 1, ncols: int = 1, figsize=(6.0, 4.2), **subplot_kw):
    """A pyplot-free figure and its axes (a single Axes for 1 × 1, else a 2-D array of Axes)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplot_kw)
    return fig, (axes[0, 0] if nrows == ncols == 1 else axes)


def _figure_of(ax) -> Any:
    if isinstance(ax, (list, tuple, np.ndarray)):
        return np.ravel(np.asarray(ax, dtype=object))[0].figure
    return ax.figure


def format_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], title: str = "") -> str:
    """A plain-text table: a title line, a header, a rule, right-aligned cells (floats as ``%.4g``)."""
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return f"{float(v):.4g}"
        return str(v)

    text = [[cell(v) for v in r] for r in rows]
    widths = [max([len(h)] + [len(r[k]) for r in text]) for k, h in enumerate(headers)]
    lines = [title] if title else []
    lines.append("  ".join(h.rjust(w) for h, w in zip(headers, widths)))
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in text]
    return "\n".join(lines)


class Result:
    """Base of the result objects: subclasses define ``_draw(ax)``, ``to_dict()`` and ``table()``.

    ``_panels`` (default 1) is the number of axes ``_draw`` wants; ``_figsize`` the size of a new figure.
    """

    _panels: int = 1
    _figsize: tuple[float, float] = (6.0, 4.2)
    reading: str = ""
    """One sentence on how to read the figure (the caption of the figure in an HTML report, ``tendyn.report``)."""

    def plot(self, ax=None):
        """Draw into ``ax`` (an Axes, or a sequence of ``_panels`` Axes) or a new figure; return the figure.

        A result with several panels given one Axes draws what fits there (a frequency response: the
        magnitude) or raises ValueError.

        Never switches the matplotlib backend and never uses pyplot.
        """
        if ax is None:
            n = self._panels
            _, ax = new_figure(1, n, figsize=(self._figsize[0] * n, self._figsize[1]))
            if n > 1:
                ax = list(ax[0])
        self._draw(ax)
        return _figure_of(ax)

    def _draw(self, ax) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def to_dict(self) -> dict:  # pragma: no cover - abstract
        raise NotImplementedError

    def to_json(self, **kw) -> str:
        """``json.dumps(self.to_dict())``."""
        return json.dumps(self.to_dict(), **kw)

    def table(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def __str__(self) -> str:
        return self.table()


def _floats(x) -> list:
    return [float(v) for v in np.asarray(x, float).ravel()]


@dataclass(eq=False)
class FrequencyResponse(Result):
    """A frequency response H(jω) = output / input on a grid (stepped sine, swept sine or analytic).

    Attributes
    ----------
    omega : ndarray
        Frequency grid [rad/s].
    ratio : ndarray of complex
        H(jω) = first harmonic (or DFT bin) of the output over that of the input, [output unit / input unit].
    output, input : str
        What is divided by what (``"F_m"``, ``"F_tau"``; ``"q_motor_2"``, ``"torque_motor_cmd_2"``).
    unit : str
        Unit of the ratio (``"-"``, ``"rad/(N·m)"``).
    method : str
        ``"stepped_sine"``, ``"swept_sine"`` or ``"analytic"``.
    amplitude : float or None
        Input amplitude [input unit] (the response of a plant with friction depends on it).
    label : str
        Legend text (default: method and amplitude).
    meta : dict
        JSON-able details of how it was obtained (cycles, rate_hz, seed, …).
    runs : list
        The time records it was computed from (not in :meth:`to_dict`).
    """

    omega: np.ndarray
    ratio: np.ndarray
    output: str = "output"
    input: str = "input"
    unit: str = "-"
    method: str = ""
    amplitude: float | None = None
    label: str = ""
    meta: dict = field(default_factory=dict)
    runs: list = field(default_factory=list, repr=False)

    _panels = 2
    _figsize = (6.0, 3.4)
    reading = ("Left: the gain |output/input| on a log scale against frequency; right: the phase; a peak of the "
               "gain is a resonance, and curves that part show the response depends on the input amplitude.")

    def __post_init__(self):
        self.omega = np.asarray(self.omega, float).ravel()
        self.ratio = np.asarray(self.ratio, complex).ravel()
        if self.omega.shape != self.ratio.shape:
            raise ValueError(f"omega {self.omega.shape} and ratio {self.ratio.shape} must have the same shape")

    # ---- views ----------------------------------------------------------------------------------
    @property
    def freq_hz(self) -> np.ndarray:
        """The grid in Hz, omega / 2π (for tables and axes)."""
        return self.omega / (2.0 * math.pi)

    @property
    def magnitude(self) -> np.ndarray:
        """|H(jω)| [unit]."""
        return np.abs(self.ratio)

    @property
    def phase_deg(self) -> np.ndarray:
        """arg H(jω) [deg], in (−180, 180]."""
        return np.degrees(np.angle(self.ratio))

    def peak_omega(self) -> float:
        """Grid frequency [rad/s] of the largest |H|."""
        return float(self.omega[int(np.argmax(self.magnitude))])

    def peak_hz(self) -> float:
        """Grid frequency [Hz] of the largest |H|."""
        return self.peak_omega() / (2.0 * math.pi)

    def peak_magnitude(self) -> float:
        return float(np.max(self.magnitude))

    def _label(self) -> str:
        if self.label:
            return self.label
        amp = f", {self.amplitude:.3g} input" if self.amplitude is not None else ""
        return f"{self.method.replace('_', ' ') or 'response'}{amp}"

    # ---- the three faces --------------------------------------------------------------------------
    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        mag_ax = axes[0]
        style = "k--" if self.method == "analytic" else ("o-" if self.method == "stepped_sine" else "-")
        kw = dict(ms=3, lw=1.2, label=self._label())
        mag_ax.semilogy(self.freq_hz, self.magnitude, style, **kw)
        mag_ax.set_ylabel(f"|{self.output} / {self.input}| [{self.unit}]")
        mag_ax.grid(alpha=0.3, which="both")
        mag_ax.legend(fontsize=8)
        if len(axes) > 1:
            axes[1].plot(self.freq_hz, self.phase_deg, style, **kw)
            axes[1].set_ylabel("phase [deg]")
            axes[1].grid(alpha=0.3)
        for a in axes[:2]:
            a.set_xlabel("frequency [Hz]")

    def to_dict(self) -> dict:
        return {"method": self.method, "output": self.output, "input": self.input, "unit": self.unit,
                "amplitude": None if self.amplitude is None else float(self.amplitude),
                "omega": _floats(self.omega), "freq_hz": _floats(self.freq_hz),
                "magnitude": _floats(self.magnitude), "phase_deg": _floats(self.phase_deg),
                "ratio_re": _floats(self.ratio.real), "ratio_im": _floats(self.ratio.imag),
                "peak_hz": self.peak_hz() if self.omega.size else None, "meta": _jsonable(self.meta)}

    def table(self, max_rows: int = 40) -> str:
        """freq [Hz] | ω [rad/s] | |H| | phase [deg]; long grids (swept sines) are shown every k-th row."""
        step = max(1, math.ceil(self.omega.size / max_rows))
        rows = [(f, w, m, p) for f, w, m, p in zip(self.freq_hz, self.omega, self.magnitude, self.phase_deg)][::step]
        title = (f"{self.output}/{self.input} ({self._label()}), peak {self.peak_hz():.4g} Hz"
                 if self.omega.size else f"{self.output}/{self.input}: empty")
        return format_table(("freq [Hz]", "omega [rad/s]", f"|H| [{self.unit}]", "phase [deg]"), rows, title)

    # ---- for pipelines ------------------------------------------------------------------------------
    @classmethod
    def analytic(cls, omega, ratio, **kw) -> "FrequencyResponse":
        """An analytic H(jω) (``method = "analytic"``)."""
        return cls(omega, ratio, method="analytic", **kw)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
