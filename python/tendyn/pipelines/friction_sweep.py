"""Simulated constant-velocity sweeps of one L-EXOS transmission under S0's strategies S1 and S2.

Runs the twin (sim.experiments.constant_velocity) and reads the log as an experimenter would: the
mean measured motor torque over each constant-speed stroke, against the commanded motor speed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.results import Result, format_table
from tendyn.sim import experiments as ex


@dataclass(eq=False)
class FrictionSweep(Result):
    """Mean measured motor torque against commanded motor speed, per strategy (S0 §III-A).

    points : strategy ("S1", "S2") → (motor speeds [rad/s], mean measured motor torques [N·m]).
    """

    device: str
    transmission: int
    points: dict = field(default_factory=dict)   # strategy -> (speeds [rad/s], mean torques [N·m])

    _figsize = (5.6, 4.2)

    def to_dict(self) -> dict:
        return {"device": self.device, "transmission": self.transmission,
                "points": {k: {"speed_motor_rad_s": v[0].tolist(), "torque_motor_Nm": v[1].tolist()}
                           for k, v in self.points.items()}}

    reading = ('Each marker is the mean motor torque of one constant-velocity test; the jump at zero speed is the '
               'Coulomb friction, the slope the viscous friction, per identification strategy.')

    def _draw(self, ax) -> None:
        for (name, (v, c)), marker in zip(self.points.items(), "os"):
            ax.plot(v, c, marker, ms=6, label=f"strategy {name}")
        ax.axhline(0, color="0.8", lw=0.8)
        ax.axvline(0, color="0.8", lw=0.8)
        ax.set_xlabel(f"motor {self.transmission} speed $\\dot q_m$ [rad/s]")
        ax.set_ylabel(f"mean measured motor {self.transmission} torque [N·m]")
        ax.set_title(f"{self.device}: constant-velocity tests, transmission {self.transmission}")
        ax.grid(alpha=0.3)
        ax.legend()

    def table(self) -> str:
        rows = [(name, float(v), float(c)) for name, (vs, cs) in self.points.items() for v, c in zip(vs, cs)]
        return format_table(("strategy", "motor speed [rad/s]", "mean motor torque [N·m]"), rows,
                            f"{self.device}: constant-velocity tests, transmission {self.transmission}")


def stroke_means(log, transmission: int, speeds, tol: float = 0.03):
    """Mean measured motor torque while the commanded motor speed is ±v (cruise only)."""
    prefix = "qd_motor_ref_" if f"qd_motor_ref_{transmission}" in log else "qd_ref_"
    ref = log[f"{prefix}{transmission}"]
    if prefix == "qd_ref_":  # joint-space references (S2): back to motor speed, other joints still
        ratio = np.max(np.abs(speeds)) / np.max(np.abs(ref))
        ref = ref * ratio
    torque = log[f"torque_motor_{transmission}"]
    v_out, c_out = [], []
    for v in speeds:
        for s in (v, -v):
            sel = np.abs(ref - s) < tol * abs(s)
            # drop the first 20 % of each cruise (PID transient)
            idx = np.flatnonzero(sel)
            if idx.size < 10:
                continue
            keep = idx[int(0.2 * idx.size):]
            v_out.append(s)
            c_out.append(float(torque[keep].mean()))
    return np.array(v_out), np.array(c_out)


def friction_sweep(device: Device | CompiledDevice, transmission: int = 2, speeds=(2.0, 5.0, 10.0, 20.0),
                   q0=None, seed: int = 0, progress=None) -> FrictionSweep:
    """Constant-velocity runs under S1 and S2 (one compiled device for both) of one transmission (1-based)
    at motor speeds [rad/s] from q0 [rad] (default: the first pose of the planned test,
    :func:`tendyn.protocols.plan_test`, with its stroke inside the joint limits), and their stroke means."""
    from tendyn.protocols import plan_test

    device = compile_device(device)
    test = plan_test(device, transmission, "S2", speeds, q0=q0, loads=1, strict=False)
    out = FrictionSweep(device.name, transmission)
    for strategy in ("S1", "S2"):
        run = ex.constant_velocity(device, transmission, speeds, strategy=strategy, travel=test.travel,
                                   q0=test.poses[0], seed=seed, progress=progress)
        out.points[strategy] = stroke_means(run.log, transmission, speeds)
    return out
