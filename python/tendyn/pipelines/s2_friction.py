"""S2 §V-C on the CEA branch: the friction protocol (claims C33–C35, Table 3).

Constant-velocity back-and-forth moves ("triangular trajectories with various amplitudes and frequencies")
at several speeds, one active-joint combination per test:

* j1 — joint 1 alone: F_V1, F_C1 (eq. 15);
* t1 — q̇5 = q̇2: Γ_fc = 0 in eqs. (16)–(17), so F_V2t1 = F_V2, F_C2t1 = F_C2, F_V5t1 = F_V5R, F_C5t1 = F_C5R;
* t2 — q̇5 = 0: F_V2t2 = F_V2 + F_V3R, F_C2t2 = F_C2 + F_C3R;
* t3 — q̇2 = 0: F_V5t3 = F_V5R + F_V3R, F_C5t3 = F_C5R + F_C3R.

Per test and moving joint the viscous + Coulomb model (eq. 15) is fitted by
:class:`tendyn.ident.friction.TransmissionFriction` on the drive's motor (plateaus found from the encoder,
gravity removed by forward/backward pairs at the same positions), then brought to the joint side: a motor
torque C reaches the joint as N C at speed q̇ = q̇_m / N, so F_C = N C_m0 and F_V = N² ν (statistics of S2
eqs. 4–7 carried along). cond(W) is reported for W in joint units (rows [1, |q̇|] of the pair
half-differences, weighted), the form of S2's "≈ 6".

Passive-joint friction (C34): F_V3R = F_V2t2 − F_V2t1 = F_V5t3 − F_V5t1 and F_C3R likewise. The decision is a
two-sided z-test per difference, z = d / √(σ₁² + σ₂²) with the two fits' standard deviations: passive
friction is declared negligible when every |z| < ``Z_DECISION`` (3: a 3σ test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.ident.friction import TransmissionFriction
from tendyn.ident.lsq import rel_stderr_pct
from tendyn.results import Result, format_table

__all__ = ["FRICTION_TESTS", "FrictionProtocol", "Z_DECISION", "joint_friction", "passive_friction_test",
           "run_friction_protocol"]

FRICTION_TESTS = {"j1": {1: 1.0}, "t1": {2: 1.0, 3: 1.0}, "t2": {2: 1.0}, "t3": {3: 1.0}}
"""Active-joint speed multipliers of each test (1-based active index: 1 = q1, 2 = q2, 3 = q5)."""
Z_DECISION = 3.0
"""|z| below which a difference of two friction coefficients is not significant (3σ)."""
TABLE3_PAPER = {"FV1": (0.020, 15.0), "FC1": (0.130, 0.9), "FV2t1": (0.021, 10.0), "FC2t1": (0.120, 0.8),
                "FV2t2": (0.022, 9.0), "FC2t2": (0.120, 0.7), "FV5t1": (0.018, 20.0), "FC5t1": (0.120, 0.9),
                "FV5t3": (0.020, 15.0), "FC5t3": (0.120, 0.9)}
"""S2 Table 3 [SEED]: value [N·m·s/rad or N·m], relative deviation [%] (F_S = F_C, and the last row is F_C5t3:
ERRATA naming)."""


def joint_friction(est: TransmissionFriction, ratio: float) -> dict:
    """Joint-side viscous [N·m·s/rad] and Coulomb [N·m] friction of a fitted drive, with σ, %σ and cond(W) in
    joint units: F_C = N C_m0, F_V = N² ν (a motor torque C is N C at the joint, q̇ = q̇_m / N)."""
    n = float(ratio)
    fc, fv = n * est.coulomb_motor_, n * n * est.viscous_motor_
    sc, sv = n * est.stderr_[0], n * n * est.stderr_[1]
    pts = est.points_
    w = np.sqrt(pts[:, 2] / pts[:, 2].mean())
    W = np.column_stack([np.sign(pts[:, 0]), pts[:, 0] / n]) * w[:, None]
    return {"FV": float(fv), "FV_stderr": float(sv), "FV_rel_stderr_pct": float(rel_stderr_pct(sv, fv)),
            "FC": float(fc), "FC_stderr": float(sc), "FC_rel_stderr_pct": float(rel_stderr_pct(sc, fc)),
            "cond": float(np.linalg.cond(W)), "speeds_joint": [float(v / n) for v in est.speeds_],
            "n_points": int(pts.shape[0])}


def passive_friction_test(rows: dict, z_max: float = Z_DECISION) -> dict:
    """C34: the differences t2 − t1 (joint 2) and t3 − t1 (joint 5) of viscous and Coulomb coefficients, their
    z-scores and the decision (passive-joint friction negligible when every |z| < z_max)."""
    out = {}
    for name, a, b in (("FV3R_from_joint2", "FV2t2", "FV2t1"), ("FC3R_from_joint2", "FC2t2", "FC2t1"),
                       ("FV3R_from_joint5", "FV5t3", "FV5t1"), ("FC3R_from_joint5", "FC5t3", "FC5t1")):
        d = rows[a]["value"] - rows[b]["value"]
        s = math.hypot(rows[a]["stderr"], rows[b]["stderr"])
        out[name] = {"difference": d, "stderr": s, "z": d / s if s > 0 else math.inf,
                     "relative_pct": 100 * d / abs(rows[b]["value"])}
    negligible = all(abs(v["z"]) < z_max for v in out.values())
    return {"differences": out, "z_max": z_max, "passive_friction_negligible": bool(negligible)}


@dataclass(eq=False)
class FrictionProtocol(Result):
    """Table 3 as identified (``rows``: name → value, stderr, rel_stderr_pct, unit, test, paper), the C34
    decision, cond(W) per fit, and the fitted points for a Fig. 5-like plot."""

    rows: dict
    decision: dict
    conds: dict
    points: dict = field(default_factory=dict, repr=False)
    paper: bool = True      # S2's twin: the table shows S2's printed values beside (tendyn.devices.is_twin_of)

    def to_dict(self) -> dict:
        return {"table3": [dict(name=k, **v) for k, v in self.rows.items()], "passive_joints": self.decision,
                "cond": self.conds, "cond_max": max(self.conds.values())}

    def table(self) -> str:
        rows = [(k, f"{v['value']:.4g}", v["unit"], f"{v['rel_stderr_pct']:.3g}", f"{v['paper'][0]:g}",
                 f"{v['paper'][1]:g}") for k, v in self.rows.items()]
        headers = ("Parameter", "Value", "Unit", "Rel. dev. %", "S2 value", "S2 rel. dev. %")
        if not self.paper:                       # another device: S2's numbers are not its numbers
            headers, rows = headers[:4], [r[:4] for r in rows]
        text = format_table(headers, rows,
                            title="Friction of the arm (S2 Table 3), joint side")
        dec = self.decision
        zs = ", ".join(f"{k}: z = {v['z']:+.2f}" for k, v in dec["differences"].items())
        return (text + "\ncond(W) of the friction fits: " + ", ".join(f"{k} {c:.3g}" for k, c in self.conds.items())
                + f"\npassive-joint friction (C34): {zs} -> "
                + ("negligible" if dec["passive_friction_negligible"] else "NOT negligible") + f" (|z| < {dec['z_max']:g})")

    reading = ('Friction torque of each constant-velocity test (half-difference of a pair of opposite speeds) '
               'against speed, per joint: the level at low speed is the Coulomb friction, the slope the viscous one.')

    def _draw(self, ax) -> None:
        for k, (v, y) in self.points.items():
            ax.plot(v, y, "o", ms=3, label=k)
        ax.set_xlabel("joint speed |q̇| [rad/s]")
        ax.set_ylabel("friction torque (half-difference of pairs) [N·m]")
        ax.set_title("friction per joint and test (S2 Fig. 5, Table 3)")
        ax.legend(fontsize=7)


def run_friction_protocol(device, q0, speeds=(0.1, 0.2, 0.3, 0.45, 0.6, 0.8), travel: float = 0.5,
                          accel: float = 4.0, seed: int = 0, rate_hz: float = 5_000.0, progress=None) -> FrictionProtocol:
    """Run j1, t1, t2, t3 on the twin at ``speeds`` [rad/s, joint side] around ``q0`` [rad] and fit Table 3.

    The estimator reads only the logs (encoders, measured torques); the drive ratios N come from the device
    description (a design value, as S2 uses Γ = N K_c I)."""
    from tendyn.device import compile_device
    from tendyn.sim.experiments import joint_friction_trajectory

    compiled = compile_device(device)
    dev = compiled.device
    ratio = [d.ratio for d in dev.drives]
    joint_of = {1: dev.drives[0].joint, 2: dev.drives[1].joint, 3: dev.drives[2].joint}
    fits, conds, points = {}, {}, {}
    for k, (test, weights) in enumerate(FRICTION_TESTS.items()):
        if progress:
            progress(f"friction test {test}")
        run = joint_friction_trajectory(compiled, weights, speeds, travel=travel, accel=accel, q0=q0,
                                        rate_hz=rate_hz, seed=seed + k, experiment=f"friction_{test}")
        for a in weights:
            est = TransmissionFriction(a, gravity="pairs", min_speeds=min(5, len(speeds)), min_speed=0.5).fit(run.log)
            jf = joint_friction(est, ratio[a - 1])
            fits[(test, joint_of[a])] = jf
            conds[f"{test}_joint{joint_of[a]}"] = jf["cond"]
            pts = est.points_
            points[f"{test}, joint {joint_of[a]}"] = (np.abs(pts[:, 0]) / ratio[a - 1], ratio[a - 1] * pts[:, 1])
    rows = {}

    def put(name, key, what, test):
        f = fits[key]
        unit = "N·m·s/rad" if what == "FV" else "N·m"
        rows[name] = {"value": f[what], "stderr": f[f"{what}_stderr"], "rel_stderr_pct": f[f"{what}_rel_stderr_pct"],
                      "unit": unit, "test": test, "paper": TABLE3_PAPER[name]}

    j1, j2, j5 = joint_of[1], joint_of[2], joint_of[3]
    put("FV1", ("j1", j1), "FV", "j1"); put("FC1", ("j1", j1), "FC", "j1")
    put("FV2t1", ("t1", j2), "FV", "t1"); put("FC2t1", ("t1", j2), "FC", "t1")
    put("FV2t2", ("t2", j2), "FV", "t2"); put("FC2t2", ("t2", j2), "FC", "t2")
    put("FV5t1", ("t1", j5), "FV", "t1"); put("FC5t1", ("t1", j5), "FC", "t1")
    put("FV5t3", ("t3", j5), "FV", "t3"); put("FC5t3", ("t3", j5), "FC", "t3")
    return FrictionProtocol(rows, passive_friction_test(rows), conds, points)
