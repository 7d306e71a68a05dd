"""Loss decomposition of the global friction over the branches of each transmission (S0 eqs. 16–21,
corrected: ERRATA; claim C9).

For an isolated move of transmission i (S1 or S2) every branch of its cable moves with the motor pulley
rim: Ṡ_j^i = k'_j^i q̇_m^i with k'_j^i = r_m^i (S0 eq. 16, corrected: ERRATA), computed here from the
routing rather than typed in. The power balance (S0 eq. 17, corrected: ERRATA — the last exponent is
(k')²) gives

    ν^i = Σ_j ν_j^i (k'_j^i)²        (S0 eq. 18)        C_m0^i = Σ_j τ_{0,j}^i |k'_j^i|      (S0 eq. 19)

and, with loss shares p (viscous) and p' (Coulomb) that sum to 1 over the branches (S0 eqs. 20–21,
corrected: ERRATA),

    ν̂_j^i = γ_j^i ν^i,  γ_j^i = p_j^i / (k'_j^i)²        τ̂_{0,j}^i = α_j^i C_m0^i,  α_j^i = p'_j^i / |k'_j^i|,

which reproduce ν^i and C_m0^i exactly. Default shares come from the device's construction: each branch
weighs as many friction elements as it carries (its pulley, or its bearings when the device file lists
them); a user can give other shares (:func:`read_shares`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tendyn.ident.friction import branch_speeds, isolated_move_joint_speeds
from tendyn.io.files import read_json
from tendyn.results import Result

SHARES_FORMAT = "tendyn.shares/1"
SHARE_TOL = 1e-6


class SharesError(ValueError):
    """Bad loss shares; ``str(err)`` is ``FILE: FIELD: problem``."""

    def __init__(self, problem: str, *, file=None, field: str | None = None):
        self.file = None if file is None else str(file)
        self.field = field
        self.problem = problem
        super().__init__(": ".join([p for p in (self.file, field) if p] + [problem]))


def kinematic_coefficients(K, motor_radius) -> np.ndarray:
    """k'[i, b] = Ṡ_b^i / q̇_m^i [m/rad] for the isolated move of transmission i (S0 eq. 16, corrected:
    ERRATA), from the routing: only joint i moves (S2), q̇_i = r_m^i / r_i^i per unit motor speed, and
    Ṡ_b^i = Σ_{l≥b} K_il q̇_l. Entries past the driven joint (b > i) are 0."""
    K = np.asarray(K, float)
    r_m = np.asarray(motor_radius, float)
    n = K.shape[0]
    out = np.zeros_like(K)
    for i in range(n):
        out[i] = branch_speeds(K, isolated_move_joint_speeds(K, r_m, i, "S2", 1.0))[i]
    return out


def default_shares(device) -> tuple[np.ndarray, np.ndarray]:
    """Shares (p, p') [-] from the construction: branch b of transmission i weighs its friction elements —
    its bearings when the device file lists them, else 1 (the pulley it runs onto) — normalised per
    transmission. Same weights for the viscous and the Coulomb part. (m, n) arrays, 0 past the driven joint."""
    arr = device.routing_arrays()
    K = arr["K"]
    m, n = K.shape
    w = np.zeros((m, n))
    for i, t in enumerate(device.transmissions):
        for b in range(t.n_branches):
            w[i, b] = max(1.0, float(arr["bearing_count"][i, b]))
    p = w / w.sum(axis=1, keepdims=True)
    return p, p.copy()


def true_shares(nu_branch, tau0_branch, kprime) -> tuple[np.ndarray, np.ndarray]:
    """The shares that per-branch values imply: p = ν_j k'_j² / ν, p' = τ_0,j |k'_j| / C_m0."""
    nu_w = np.asarray(nu_branch, float) * np.asarray(kprime, float) ** 2
    c_w = np.asarray(tau0_branch, float) * np.abs(kprime)
    return nu_w / nu_w.sum(axis=1, keepdims=True), c_w / c_w.sum(axis=1, keepdims=True)


@dataclass(eq=False)
class LossDecomposition(Result):
    """Per-branch estimates ν̂ [N·s/m], τ̂_0 [N] of every transmission and the checks of eqs. (18)–(19).

    Arrays are (m, n): row i = transmission i + 1, column b = branch b (0 = base, b = link b).
    """

    device: str
    kprime: np.ndarray
    p: np.ndarray
    p_prime: np.ndarray
    gamma: np.ndarray
    alpha: np.ndarray
    nu_branch: np.ndarray
    tau0_branch: np.ndarray
    viscous_motor: np.ndarray        # global ν^i given [N·m·s/rad]
    coulomb_motor: np.ndarray        # global C_m0^i given [N·m]
    branches: list
    load_coefficient: np.ndarray | None = None   # c_L^i [-] when identified (carried to the reducer, loss_model)

    def reproduced(self) -> tuple[np.ndarray, np.ndarray]:
        """(ν, C_m0) recomputed from the branch values through S0 eqs. (18)–(19)."""
        return ((self.nu_branch * self.kprime ** 2).sum(axis=1),
                (self.tau0_branch * np.abs(self.kprime)).sum(axis=1))

    def max_mismatch(self) -> float:
        """Largest relative difference between the given and the reproduced global values."""
        nu, c0 = self.reproduced()
        scale = lambda a: np.maximum(np.abs(a), 1e-300)   # noqa: E731
        return float(max(np.max(np.abs(nu - self.viscous_motor) / scale(self.viscous_motor)),
                         np.max(np.abs(c0 - self.coulomb_motor) / scale(self.coulomb_motor))))

    def to_dict(self) -> dict:
        rows = []
        for i, nb in enumerate(self.branches):
            rows.append({"transmission": i + 1,
                         "coulomb_motor": float(self.coulomb_motor[i]), "viscous_motor": float(self.viscous_motor[i]),
                         "kprime": self.kprime[i, :nb].tolist(), "p": self.p[i, :nb].tolist(),
                         "p_prime": self.p_prime[i, :nb].tolist(), "gamma": self.gamma[i, :nb].tolist(),
                         "alpha": self.alpha[i, :nb].tolist(), "nu_branch": self.nu_branch[i, :nb].tolist(),
                         "tau0_branch": self.tau0_branch[i, :nb].tolist()})
            if self.load_coefficient is not None:
                rows[-1]["load_coefficient"] = float(self.load_coefficient[i])
        return {"format": "tendyn.decomposition/1", "device": self.device,
                "units": {"kprime": "m/rad", "nu_branch": "N·s/m", "tau0_branch": "N", "gamma": "1/m^2",
                          "alpha": "rad/m", "load_coefficient": "-"},
                "max_relative_mismatch": self.max_mismatch(), "transmissions": rows}

    def table(self) -> str:
        lines = [f"{self.device}: loss decomposition (S0 eqs. 18–21, corrected: ERRATA)",
                 f"{'tr.':<4}{'branch':<8}{'k´ [m]':>10}{'p':>8}{'p´':>8}{'ν_j [N·s/m]':>14}{'τ0_j [N]':>12}"]
        for i, nb in enumerate(self.branches):
            for b in range(nb):
                lines.append(f"{i + 1:<4}{b:<8}{self.kprime[i, b]:>10.4g}{self.p[i, b]:>8.3f}"
                             f"{self.p_prime[i, b]:>8.3f}{self.nu_branch[i, b]:>14.4g}{self.tau0_branch[i, b]:>12.4g}")
        lines.append(f"global values reproduced within {self.max_mismatch():.1e} (relative)")
        return "\n".join(lines)

    reading = ('For each transmission, the identified Coulomb force τ̂_0 on each branch of its route (0 = base); a '
               'branch whose value stands out carries most of the losses.')

    def _draw(self, ax) -> None:
        """τ̂_0 per branch (markers and lines, one per transmission) against the branch number."""
        for i, nb in enumerate(self.branches):
            ax.plot(range(nb), self.tau0_branch[i, :nb], "o-", label=f"transmission {i + 1}")
        ax.set_xlabel("branch (0 = base, b = link b)")
        ax.set_ylabel("τ̂_0 per branch [N]")
        ax.set_xticks(range(max(self.branches)))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)


def decompose(device, coulomb_motor, viscous_motor, p=None, p_prime=None, load_coefficient=None) -> LossDecomposition:
    """Per-branch τ̂_0 and ν̂ from global C_m0^i [N·m], ν^i [N·m·s/rad] (one per transmission) and the
    shares (default :func:`default_shares`). S0 eqs. 20–21, corrected: ERRATA. An identified load coefficient
    c_L^i [-] is carried as it is: it belongs to the cable's tension, not to a branch's speed, and the loss model
    places it at the reducer (:mod:`tendyn.ident.loss_model`)."""
    from tendyn.device.routing_checks import require_separable

    require_separable(device, "the loss decomposition")  # what S0's method cannot separate: its docstring
    arr = device.routing_arrays()
    K, r_m = arr["K"], arr["motor_radius"]
    kp = kinematic_coefficients(K, r_m)
    branches = [t.joint for t in device.transmissions]
    if p is None or p_prime is None:
        dp, dpp = default_shares(device)
        p = dp if p is None else p
        p_prime = dpp if p_prime is None else p_prime
    p = np.asarray(p, float)
    p_prime = np.asarray(p_prime, float)
    check_shares(p, p_prime, branches)
    c0 = np.asarray(coulomb_motor, float)
    nu = np.asarray(viscous_motor, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.where(kp != 0, p / kp ** 2, 0.0)
        alpha = np.where(kp != 0, p_prime / np.abs(kp), 0.0)
    load = None if load_coefficient is None else np.asarray(load_coefficient, float)
    return LossDecomposition(device.name, kp, p, p_prime, gamma, alpha, gamma * nu[:, None],
                             alpha * c0[:, None], nu, c0, branches, load)


def check_shares(p, p_prime, branches, source=None) -> None:
    """Shares are ≥ 0, zero past the driven joint and sum to 1 per transmission (S0 eqs. 20–21)."""
    for name, arr in (("p", p), ("p_prime", p_prime)):
        for i, nb in enumerate(branches):
            where = f"transmissions[{i + 1}].{name}"
            row = arr[i]
            if not np.all(np.isfinite(row)) or np.any(row < 0):
                raise SharesError("shares must be finite and >= 0", file=source, field=where)
            if np.any(row[nb:] != 0):
                raise SharesError(f"transmission {i + 1} has {nb} branches; shares past them must be 0",
                                  file=source, field=where)
            if abs(row[:nb].sum() - 1.0) > SHARE_TOL:
                raise SharesError(f"must sum to 1 (got {row[:nb].sum():.6g})", file=source, field=where)


def read_shares(path, device) -> tuple[np.ndarray, np.ndarray]:
    """Read a shares file (JSON, ``{"format": "tendyn.shares/1", "transmissions": [{"transmission": 1,
    "p": [...], "p_prime": [...]}, ...]}``, one list entry per branch 0…i−1); every transmission of the
    device must be there."""
    path = Path(path)
    try:
        doc = read_json(path)
    except OSError as e:
        raise SharesError(f"cannot read: {e.strerror or e}", file=path) from None
    except json.JSONDecodeError as e:
        raise SharesError(f"not JSON: {e.msg} (line {e.lineno})", file=path) from None
    if not isinstance(doc, dict) or doc.get("format") != SHARES_FORMAT:
        raise SharesError(f"must be {SHARES_FORMAT!r}", file=path, field="format")
    branches = [t.joint for t in device.transmissions]
    m, n = len(branches), device.n_joints
    p, pp = np.zeros((m, n)), np.zeros((m, n))
    seen = set()
    rows = doc.get("transmissions")
    if not isinstance(rows, list):
        raise SharesError("must be a list", file=path, field="transmissions")
    for k, row in enumerate(rows):
        t = row.get("transmission") if isinstance(row, dict) else None
        if not isinstance(t, int) or not 1 <= t <= m or t in seen:
            raise SharesError(f"must be a new integer in 1…{m} (got {t!r})", file=path,
                              field=f"transmissions[{k + 1}].transmission")
        seen.add(t)
        for name, arr in (("p", p), ("p_prime", pp)):
            vals = row.get(name)
            if not isinstance(vals, list) or len(vals) != branches[t - 1] or \
                    not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in vals):
                raise SharesError(f"must be {branches[t - 1]} finite numbers (one per branch)", file=path,
                                  field=f"transmissions[{t}].{name}")
            arr[t - 1, :len(vals)] = vals
    for t in range(1, m + 1):
        if t not in seen:
            raise SharesError(f"transmission {t} missing", file=path, field="transmissions")
    check_shares(p, pp, branches, source=path)
    return p, pp


def drive_split(dev, doc) -> dict:
    """Capstan drives: each drive is one cable stretch (no branches to split, S0 eqs. 18–21 reduce to one term):
    its identified motor-side C_m0 [N·m] and ν [N·m·s/rad] and what they are at the joint (N C_m0 [N·m],
    N² ν [N·m·s/rad]) beside the device file's values (information, not used by the fit)."""
    rows = []
    for k, d in enumerate(dev.drives):
        c0, nu = float(doc["coulomb_motor"][k]), float(doc["viscous_motor"][k])
        rows.append({"drive": k + 1, "name": d.name, "joint": d.joint, "ratio": d.ratio, "branches": 1,
                     "coulomb_motor": c0, "viscous_motor": nu, "coulomb_joint": d.ratio * c0,
                     "viscous_joint": d.ratio ** 2 * nu, "file_coulomb_motor": d.coulomb_motor,
                     "file_viscous_motor": d.viscous_motor})
    return {"format": "tendyn.decomposition/1", "device": dev.name, "kind": "drives",
            "note": "capstan drives: one cable stretch per drive, nothing to split", "drives": rows}


def decompose_friction(calibrated):
    """The decomposition of a calibrated device's identified friction (``tendyn decompose``), the document read
    once by :func:`tendyn.ident.calibrated.calibrate` with its shares: cable transmissions, the per-branch
    :class:`LossDecomposition` its loss model was built from (S0 eqs. 18–21, corrected: ERRATA; c_L carried);
    capstan drives, :func:`drive_split` of the motor-side values (one cable stretch each, nothing to split).

    Raises
    ------
    ValueError
        a device calibrated without FRICTION.json (``tendyn.friction/1``);
        :class:`tendyn.ident.calibrated.CalibrationError` for a routing S0 cannot separate (a differential).
    """
    if calibrated.friction is None:
        raise ValueError(f"{calibrated.name}: no identified friction (FRICTION.json, tendyn.friction/1) to decompose")
    dev = calibrated.device
    if not dev.transmissions:
        return drive_split(dev, calibrated.friction)
    return calibrated.loss_model().decomposition
