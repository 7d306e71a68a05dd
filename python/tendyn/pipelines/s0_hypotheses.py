"""Switches for S0's working hypotheses (C12), each measured on the twin with the Fig. 7 hand experiment.

S0 §III-B builds its compensator on three hypotheses; each is a switch here, and the twin — which keeps all
its physics whatever the switch — tells what each costs:

* ``efficiencies``: ``"neglected"`` (S0: reducer and cable efficiencies negligible beside the bearings, so the
  compensator's model has β = 0 and η_d = 1) or ``"modelled"`` (β and η_d of the model kept);
* ``static_friction``: ``"not compensated"`` (S0: with position sensors only the direction of a motion that
  has not started is unknown; the friction feedforward fades to zero below the velocity band) or
  ``"compensated"`` (full feedforward as soon as the encoders show motion, band 0.02 rad/s);
* ``sensors``: ``"position only"`` (S0: quantised motor encoders, velocity from filtered differences) or
  ``"ideal"`` (the exact motor positions: what a perfect encoder/tachometer would give).

:func:`hypotheses_experiment` runs the paper's setting, then flips one switch at a time, and reports the C11
reduction and the energy the device gives the hand per cycle (> 0: it injects energy, not passive).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendyn.control.compensator import (DEFAULT_UNDERESTIMATION, DEFAULT_VELOCITY_BAND, DEFAULT_VELOCITY_CUTOFF_HZ,
                                        transmission_with_friction)
from tendyn.results import Result, format_table

from .s0_compensation import HandRun, _device, hand_run

__all__ = ["PAPER", "HYPOTHESES", "Hypotheses", "HypothesesResult", "hypotheses_experiment"]

STATIC_COMPENSATION_BAND = 0.02
"""v_band [rad/s] motor side when static friction is 'compensated': full feedforward from 2 % of the default
band, i.e. as soon as the encoders see the motion start."""

HYPOTHESES = {
    "efficiencies": ("neglected", "modelled"),
    "static_friction": ("not compensated", "compensated"),
    "sensors": ("position only", "ideal"),
}
"""Each switch and its values; the first value is S0's hypothesis."""


@dataclass(frozen=True)
class Hypotheses:
    """One setting of the three switches (defaults: S0's hypotheses)."""

    efficiencies: str = "neglected"
    static_friction: str = "not compensated"
    sensors: str = "position only"

    def __post_init__(self):
        for name, values in HYPOTHESES.items():
            if getattr(self, name) not in values:
                raise ValueError(f"{name} must be one of {', '.join(map(repr, values))} "
                                 f"(got {getattr(self, name)!r})")

    def flipped(self, name: str) -> "Hypotheses":
        """The same setting with switch ``name`` set to its other value."""
        a, b = HYPOTHESES[name]
        return Hypotheses(**{**self.__dict__, name: b if getattr(self, name) == a else a})

    def label(self) -> str:
        return ", ".join(f"{k} {getattr(self, k)}" for k in HYPOTHESES)

    def hand_options(self, device, friction=None) -> dict:
        """The :func:`hand_run` options that realise this setting (the twin itself is never changed)."""
        opts = {"friction": friction,
                "encoders": "quantised" if self.sensors == "position only" else "exact",
                "velocity_band": DEFAULT_VELOCITY_BAND if self.static_friction == "not compensated"
                else STATIC_COMPENSATION_BAND,
                "velocity_cutoff_hz": DEFAULT_VELOCITY_CUTOFF_HZ if self.sensors == "position only" else 0.0}
        if self.efficiencies == "neglected":
            t = transmission_with_friction(device, friction).to_dict()
            n = t["tau0"].shape[0]
            source = "device" if friction is None else "identified"
            opts["friction"] = {"tau0": t["tau0"], "nu": t["nu"], "beta": np.zeros((n, n)),
                                "reducer_efficiency": np.ones(n),
                                "sources": {"tau0": source, "nu": source, "beta": "none", "bearings": "none",
                                            "reducer_efficiency": "none"}}
        return opts


PAPER = Hypotheses()
"""S0's three hypotheses."""


@dataclass(eq=False)
class HypothesesResult(Result):
    """The hand experiment with gravity compensation only and with each setting of the switches.

    Attributes
    ----------
    gravity_only : HandRun (k = 0)
    runs : list of (Hypotheses, flipped switch name or "", HandRun) — the paper's setting first
    device : name
    """

    gravity_only: HandRun
    runs: list
    device: str = "L-EXOS"
    _figsize = (7.0, 4.2)

    def reduction(self, run: HandRun) -> float:
        """1 − RMS(run) / RMS(gravity only) of the joint-1 hand torque [-] (C11)."""
        return 1.0 - run.rms_joint1 / self.gravity_only.rms_joint1

    def by_switch(self, name: str = "") -> HandRun:
        """The run with switch ``name`` flipped from the paper's setting ("" = the paper's setting)."""
        return next(r for _, flipped, r in self.runs if flipped == name)

    reading = ("Each bar is the reduction of the joint-1 hand torque with one of S0's hypotheses switched off (blue: "
               'all on); bars left of the red line at 50 % miss claim C11.')

    def _draw(self, ax) -> None:
        names = ["S0 hypotheses"] + [f"{n}: {h.__dict__[n]}" for h, n, _ in self.runs if n]
        red = [100 * self.reduction(r) for _, _, r in self.runs]
        energy = [r.energy_to_hand_per_cycle for _, _, r in self.runs]
        bars = ax.barh(names, red, color=["tab:blue"] + ["tab:gray"] * (len(names) - 1))
        for b, e in zip(bars, energy):
            ax.text(b.get_width(), b.get_y() + b.get_height() / 2, f"  {e:+.2f} J/cycle", va="center", fontsize=8)
        ax.axvline(50.0, color="tab:red", lw=0.8, ls="--", label="C11: 50 %")
        ax.set_xlim(0.0, 1.3 * max(red + [50.0]))
        ax.set_xlabel("reduction of the joint-1 hand torque vs gravity compensation only [%]")
        ax.set_title(f"{self.device}: S0's hypotheses switched one at a time (C12)")
        ax.invert_yaxis()
        ax.legend(loc="lower right", fontsize=8)

    def to_dict(self) -> dict:
        return {"device": self.device,
                "underestimation": self.runs[0][2].underestimation,
                "rms_joint1_gravity_only": self.gravity_only.rms_joint1,
                "settings": [{"flipped": n or None, **h.__dict__, "rms_joint1": r.rms_joint1,
                              "reduction_joint1": float(self.reduction(r)),
                              "energy_to_hand_per_cycle": r.energy_to_hand_per_cycle} for h, n, r in self.runs]}

    def table(self) -> str:
        rows = [(n or "(S0 hypotheses)", h.__dict__[n] if n else "—", r.rms_joint1, 100 * self.reduction(r),
                 r.energy_to_hand_per_cycle) for h, n, r in self.runs]
        return format_table(("switch flipped", "to", "RMS joint-1 [N·m]", "reduction [%]", "energy to hand [J/cycle]"),
                            rows, title=f"S0 hypotheses on the {self.device} twin (C12); gravity only: "
                                        f"{self.gravity_only.rms_joint1:.4g} N·m")


def hypotheses_experiment(device="lexos", *, underestimation: float = DEFAULT_UNDERESTIMATION, friction=None,
                          base: Hypotheses = PAPER, seed: int = 7, **hand) -> HypothesesResult:
    """Run the hand experiment (:func:`tendyn.pipelines.s0_compensation.hand_run`) with gravity compensation
    only, with ``base`` (default S0's hypotheses) and with each switch of ``base`` flipped alone.

    ``friction``: the losses the compensator starts from (None: the twin's own); the twin keeps its true ones.
    """
    compiled = _device(device)
    g = hand_run(compiled, 0.0, seed=seed, **hand)
    runs = []
    for name in [""] + list(HYPOTHESES):
        h = base.flipped(name) if name else base
        runs.append((h, name, hand_run(compiled, underestimation, seed=seed, **hand,
                                       **h.hand_options(compiled, friction))))
    return HypothesesResult(g, runs, device=compiled.name)
