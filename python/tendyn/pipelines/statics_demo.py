"""S0 statics on a device: motor torque needed vs joint torque delivered, with losses.

For one joint at a time the joint moves at constant speed while the others stand still
(motors of the crossing cables follow, as in strategy S2); the joint torque wanted is swept and the
feedforward statics (C++ core) gives the motor torque to command. Positive joint power = the motor
drives the joint; negative = the joint back-drives the cable. The lossless line is C_m = R_m K⁻ᵀ τ_J.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.device import CompiledDevice, SerialDevice, compile_device
from tendyn.results import Result, format_table


@dataclass
class JointSweep:
    joint: int                       # 0-based
    speed: float                     # joint speed used [rad/s]
    torque_joint: np.ndarray         # swept joint torque [N·m]
    motor_lossless: np.ndarray       # [N·m]
    motor_positive_speed: np.ndarray # joint moving at +speed [N·m]
    motor_negative_speed: np.ndarray # joint moving at −speed [N·m]


@dataclass(eq=False)
class StaticsDemo(Result):
    """Motor torque needed vs joint torque delivered, one :class:`JointSweep` per swept joint (one panel each)."""

    device: str
    sweeps: list[JointSweep] = field(default_factory=list)

    _figsize = (5.2, 4.4)

    @property
    def _panels(self) -> int:
        return max(1, len(self.sweeps))

    def to_dict(self) -> dict:
        out = {"device": self.device, "sweeps": []}
        for s in self.sweeps:
            out["sweeps"].append({
                "joint": s.joint + 1, "speed_rad_s": s.speed,
                "torque_joint_Nm": s.torque_joint.tolist(),
                "motor_torque_lossless_Nm": s.motor_lossless.tolist(),
                "motor_torque_positive_speed_Nm": s.motor_positive_speed.tolist(),
                "motor_torque_negative_speed_Nm": s.motor_negative_speed.tolist(),
            })
        return out

    reading = ('For each transmission: the motor torque needed (vertical) to deliver a joint torque (horizontal), '
               'lossless (dashed) and with the losses at either speed; the gap is the friction.')

    def _draw(self, ax) -> None:
        """One panel per swept joint: ``ax`` is one Axes per sweep (or one Axes for a single sweep)."""
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        if len(axes) != len(self.sweeps):
            raise ValueError(f"StaticsDemo.plot needs one Axes per swept joint ({len(self.sweeps)}), "
                             f"got {len(axes)}")
        for ax, s in zip(axes, self.sweeps):
            tj = s.torque_joint
            ax.plot(tj, s.motor_lossless, "k--", lw=1.2, label="lossless  $C_m = R_m K^{-T}\\tau_J$")
            for motor, sign, colour in ((s.motor_positive_speed, +1, "tab:blue"),
                                        (s.motor_negative_speed, -1, "tab:red")):
                drive = tj * sign > 0
                ax.plot(tj[drive], motor[drive], color=colour, lw=2.2,
                        label=f"$\\dot q$ = {sign * s.speed:+.1f} rad/s, motor drives")
                ax.plot(tj[~drive], motor[~drive], color=colour, lw=2.2, ls=":",
                        label=f"$\\dot q$ = {sign * s.speed:+.1f} rad/s, joint back-drives")
            ax.axhline(0, color="0.8", lw=0.8)
            ax.axvline(0, color="0.8", lw=0.8)
            ax.set_xlabel(f"joint {s.joint + 1} torque delivered $\\tau_J$ [N·m]")
            ax.set_ylabel(f"motor {s.joint + 1} torque needed $C_m$ [N·m]")
            ax.set_title(f"{self.device}: transmission {s.joint + 1}")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7.5, loc="upper left")

    def table(self) -> str:
        """At the largest swept joint torque: motor torque driving, back-driven and lossless (S0 Table style)."""
        rows = []
        for s in self.sweeps:
            k = len(s.torque_joint) - 1
            rows.append((s.joint + 1, s.speed, float(s.torque_joint[k]), float(s.motor_lossless[k]),
                         float(s.motor_positive_speed[k]), float(s.motor_negative_speed[k])))
        return format_table(("joint", "speed [rad/s]", "tau_J [N·m]", "C_m lossless [N·m]", "C_m at +speed [N·m]",
                             "C_m at -speed [N·m]"), rows, f"{self.device}: statics with losses")


def statics_demo(device: SerialDevice | CompiledDevice, joints=None, speed: float = 0.5,
                 torque_max: float | None = None, points: int = 201) -> StaticsDemo:
    """Sweep joint torque for each joint in ``joints`` (0-based; default the first and the last joint) at
    ±``speed`` [rad/s], up to ``torque_max`` [N·m] (default: what half the motor's continuous torque gives at the
    joint through its own cable)."""
    device = compile_device(device)
    tr = device.transmission
    if tr is None:
        raise ValueError(f"{device.name} has no cable transmissions: statics with losses need [[transmissions]]")
    joints = sorted({0, tr.n - 1}) if joints is None else joints
    motors = [t.motor for t in device.device.transmissions]
    demo = StaticsDemo(device.name)
    for j in joints:
        if not 0 <= j < tr.n:
            raise ValueError(f"joint {j + 1} does not exist on {device.name} ({tr.n} joints)")
        tmax = torque_max if torque_max is not None else \
            0.5 * motors[j].continuous_torque * tr.K[j, j] / tr.model.motor_radius[j]
        tj = np.linspace(-tmax, tmax, points)
        lossless, pos, neg = (np.empty(points) for _ in range(3))
        for k, t in enumerate(tj):
            tau = np.zeros(tr.n)
            tau[j] = t
            qd = np.zeros(tr.n)
            lossless[k] = tr.feedforward(tau, losses=False).torque_motor[j]
            qd[j] = speed
            pos[k] = tr.feedforward(tau, qd).torque_motor[j]
            qd[j] = -speed
            neg[k] = tr.feedforward(tau, qd).torque_motor[j]
        demo.sweeps.append(JointSweep(j, speed, tj, lossless, pos, neg))
    return demo
