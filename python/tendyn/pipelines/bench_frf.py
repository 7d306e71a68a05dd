"""S1 on the McGill twin: open-loop FRF |F_m/F_τ| at several input amplitudes next to the analytic G(s)
of eq. (2) — friction inside the loop moves the resonance with amplitude (C22)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.analysis.tendon_drive import frequency_response
from tendyn.device import CompiledDevice, compile_device
from tendyn.device.tendon_bench import TendonBench
from tendyn.results import FrequencyResponse, Result, format_table
from tendyn.sim.tendon_bench import stepped_sine


@dataclass(eq=False)
class BenchFRF(Result):
    """Stepped-sine FRFs of one bench at several input amplitudes, and the friction-free analytic G(jω).

    Attributes
    ----------
    device : str
    analytic : FrequencyResponse
        G(jω) of S1 eq. (2), friction-free plant.
    measured : dict of float to FrequencyResponse
        Input amplitude [N] → first-harmonic F_m/F_τ of the twin.
    """

    device: str
    analytic: FrequencyResponse
    measured: dict = field(default_factory=dict)

    @property
    def omega(self) -> np.ndarray:
        """The common grid [rad/s]."""
        return self.analytic.omega

    def peaks_hz(self) -> dict:
        """Input amplitude [N] → grid frequency [Hz] of the largest measured |F_m/F_τ|."""
        return {a: r.peak_hz() for a, r in self.measured.items()}

    reading = ('The dashed black curve is the analytic linear plant; each coloured curve a stepped sine at one input '
               'amplitude: the peak moves with the amplitude where friction matters.')

    def _draw(self, ax) -> None:
        self.analytic.plot(ax)
        for r in self.measured.values():
            r.plot(ax)
        ax.set_ylabel("|F_m / F_τ| [-] (first harmonic)")
        ax.set_title(f"{self.device}: open loop, very stiff load")

    def to_dict(self) -> dict:
        return {"device": self.device, "omega": self.omega.tolist(),
                "freq_hz": self.analytic.freq_hz.tolist(),
                "analytic_magnitude": self.analytic.magnitude.tolist(),
                "measured_magnitude": {str(a): r.magnitude.tolist() for a, r in self.measured.items()},
                "peak_hz": {str(a): f for a, f in self.peaks_hz().items()}}

    def table(self) -> str:
        rows = [(a, r.peak_hz(), r.peak_magnitude()) for a, r in self.measured.items()]
        rows.append(("analytic", self.analytic.peak_hz(), self.analytic.peak_magnitude()))
        return format_table(("input [N]", "peak [Hz]", "|F_m/F_tau| at peak"), rows,
                            f"{self.device}: open-loop resonance vs input amplitude (S1, C22)")


def bench_frf(bench: TendonBench | CompiledDevice, amplitudes=(0.31, 0.34, 0.38, 0.6), omega=None) -> BenchFRF:
    """Stepped sines at each amplitude [N] on ``omega`` [rad/s] (default 8…40 Hz every 1 Hz)."""
    compiled = compile_device(bench)
    bench = compiled.device
    omega = 2 * math.pi * np.arange(8.0, 41.0, 1.0) if omega is None else np.asarray(omega, float)
    analytic = FrequencyResponse.analytic(omega, frequency_response(bench.plant_params(), omega), output="F_m",
                                          input="F_tau", label="G(jω), eq. (2), no friction")
    out = BenchFRF(bench.name, analytic)
    for a in amplitudes:
        out.measured[float(a)] = stepped_sine(compiled, omega=omega, amplitude_N=a)
    return out
