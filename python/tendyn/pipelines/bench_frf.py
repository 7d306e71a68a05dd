"""S1 on the McGill twin: open-loop FRF |F_m/F_τ| at several input amplitudes next to the analytic G(s)
of eq. (2) — friction inside the loop moves the resonance with amplitude (C22)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.analysis.tendon_drive import frequency_response
from tendyn.sim.tendon_bench import stepped_sine


@dataclass
class BenchFRF:
    device: str
    freqs_hz: np.ndarray
    analytic: np.ndarray                                  # complex G(jω), friction-free plant
    measured: dict = field(default_factory=dict)          # amplitude [N] -> complex first-harmonic ratio

    def peaks_hz(self) -> dict:
        return {a: float(self.freqs_hz[int(np.argmax(np.abs(r)))]) for a, r in self.measured.items()}

    def to_dict(self) -> dict:
        return {"device": self.device, "freqs_hz": self.freqs_hz.tolist(),
                "analytic_magnitude": np.abs(self.analytic).tolist(),
                "measured_magnitude": {str(a): np.abs(r).tolist() for a, r in self.measured.items()},
                "peak_hz": {str(a): f for a, f in self.peaks_hz().items()}}

    def plot(self, path=None):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.0, 4.2))
        ax.semilogy(self.freqs_hz, np.abs(self.analytic), "k--", lw=1.2, label="G(jω), eq. (2), no friction")
        for a, r in self.measured.items():
            ax.semilogy(self.freqs_hz, np.abs(r), "o-", ms=3, lw=1.2, label=f"twin, {a:.2f} N input")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("|F_m / F_τ| (first harmonic)")
        ax.set_title(f"{self.device}: open loop, very stiff load")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        fig.tight_layout()
        if path is not None:
            from tendyn.io import save_png

            save_png(fig, path)
        return fig


def bench_frf(bench, amplitudes=(0.31, 0.34, 0.38, 0.6), freqs_hz=None) -> BenchFRF:
    freqs = np.arange(8.0, 41.0, 1.0) if freqs_hz is None else np.asarray(freqs_hz, float)
    out = BenchFRF(getattr(bench, "name", "McGill bench"), freqs,
                   frequency_response(bench.plant_params(), 2 * np.pi * freqs))
    for a in amplitudes:
        out.measured[float(a)] = stepped_sine(bench, freqs, a).ratio
    return out
