"""S0 statics on a device: motor torque needed vs joint torque delivered, with losses.

For one joint at a time the joint moves at constant speed while the others stand still
(motors of the crossing cables follow, as in strategy S2); the joint torque wanted is swept and the
feedforward statics (C++ core) gives the motor torque to command. Positive joint power = the motor
drives the joint; negative = the joint back-drives the cable. The lossless line is C_m = R_m K⁻ᵀ τ_J.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendyn.transmission import Transmission


@dataclass
class JointSweep:
    joint: int                       # 0-based
    speed: float                     # joint speed used [rad/s]
    torque_joint: np.ndarray         # swept joint torque [N·m]
    motor_lossless: np.ndarray       # [N·m]
    motor_positive_speed: np.ndarray # joint moving at +speed [N·m]
    motor_negative_speed: np.ndarray # joint moving at −speed [N·m]


@dataclass
class StaticsDemo:
    device: str
    sweeps: list[JointSweep] = field(default_factory=list)

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

    def plot(self, path=None):
        """One panel per swept joint: motor torque needed vs joint torque delivered."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(self.sweeps), figsize=(5.2 * len(self.sweeps), 4.4), squeeze=False)
        for ax, s in zip(axes[0], self.sweeps):
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
        fig.tight_layout()
        if path is not None:
            from tendyn.io import save_png

            save_png(fig, path)
        return fig


def statics_demo(device, joints=(0, 3), speed: float = 0.5, torque_max: float | None = None,
                 points: int = 201) -> StaticsDemo:
    """Sweep joint torque for each joint in ``joints`` (0-based) at ±``speed`` [rad/s]."""
    tr = Transmission.from_device(device)
    demo = StaticsDemo(device.name)
    for j in joints:
        if not 0 <= j < tr.n:
            raise ValueError(f"joint {j + 1} does not exist on {device.name} ({tr.n} joints)")
        tmax = torque_max if torque_max is not None else 0.7 * tr.K[j, j] / tr.model.motor_radius[j] * 0.5
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
