"""Blocked-link tests on every capstan drive of a device (S2 §V-C): torque vs motor angle.

With the links blocked, a triangular motor torque winds the motor against the capstan cable: the
slope of torque over angle is the stiffness seen at the motor (K_T, S2 Table 2, ERRATA eq. 19) and the
loop's width is the friction (hysteresis). A least-squares line per drive, fitted to the logged encoder
angle and commanded torque, gives the slope (the full K, B, offset fit of S2 §V-C is the identification's).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.sim import experiments as ex


@dataclass
class BlockedLinkDemo:
    """Per drive: motor angle from its start [rad], commanded motor torque [N·m], fitted slope [N·m/rad]."""

    device: str
    angle: dict[str, np.ndarray] = field(default_factory=dict)
    torque: dict[str, np.ndarray] = field(default_factory=dict)
    stiffness_motor: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"device": self.device, "stiffness_motor_Nm_rad": dict(self.stiffness_motor),
                "angle_rad": {k: v.tolist() for k, v in self.angle.items()},
                "torque_motor_Nm": {k: v.tolist() for k, v in self.torque.items()}}

    def table(self) -> str:
        from tendyn.results import format_table

        return format_table(("drive", "slope [N·m/rad] (motor side)"),
                            [(name, f"{k:.3f}") for name, k in self.stiffness_motor.items()])

    __str__ = table

    reading = ('Motor torque against motor angle with the links blocked: the slope of each loop is the capstan '
               'stiffness (legend), its width the friction hysteresis.')

    def plot(self, ax=None):
        """Torque vs angle per drive into ``ax`` (or a new figure); returns the figure."""
        from matplotlib.figure import Figure

        if ax is None:
            ax = Figure(figsize=(5.6, 4.2)).subplots()
        for name, k in self.stiffness_motor.items():
            ax.plot(self.angle[name] * 1e3, self.torque[name], lw=1.2,
                    label=f"{name}: slope {k:.2f} N·m/rad")
        ax.set_xlabel("motor angle [mrad] (links blocked)")
        ax.set_ylabel("motor torque [N·m]")
        ax.set_title(f"{self.device}: capstan stiffness and friction hysteresis")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.figure.tight_layout()
        return ax.figure


def blocked_link_demo(device, torque_amplitude: float = 0.1, period: float = 2.0, cycles: int = 1,
                      seed: int = 0) -> BlockedLinkDemo:
    """Blocked-link test of each drive in turn (torque amplitude [N·m], triangle period [s])."""
    out = BlockedLinkDemo(device.name)
    for k, d in enumerate(device.drives):
        run = ex.blocked_link(device, joint=k + 1, torque_amplitude=torque_amplitude, period=period,
                              cycles=cycles, seed=seed)
        encoder = np.asarray(run.log[f"q_motor_{k + 1}"])     # what the bench records, not the twin's truth
        qm = encoder - encoder[0]
        tau = np.asarray(run.log[f"torque_motor_cmd_{k + 1}"])
        out.angle[d.name], out.torque[d.name] = qm, tau
        out.stiffness_motor[d.name] = float(np.polyfit(qm, tau, 1)[0])
    return out
