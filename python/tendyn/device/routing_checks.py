"""Checks of a general cable routing (issue 19): invertible, power-consistent, cables kept taut.

A routing is the matrix K [m] of R_m q_m = K q (S0 eqs. 1-2, ERRATA) built from the ``[[transmissions]]`` of a
device file: row i is the cable of transmission i, column j the signed radius of the pulley of joint j it
wraps (crossed joints before or after its driven joint, the driven radius on the diagonal). The loader calls
:func:`check_transmissions`; the core (``include/tendyn/routing.hpp``) finds the structure (blocks, the first
dependent transmission), Python only words the problem for the file.

:func:`check_tendons` checks an N+1 routing (``[device] routing = "n_plus_one"``: n + 1 tendons share n joints)
through the core's ``tendyn._core.TendonModel`` (``include/tendyn/tendons.hpp``): full row rank of the joint map
Kᵀ, tension closure (a null vector h > 0 of Kᵀ), virtual work, and tension floors within the motors' reach.
:func:`tendon_coupling` analyses any routing with more cables than joints (N+1, 2N, …) by a linear programme:
rank, tension closure and the minimum pretension that keeps every cable taut over a box of joint torques.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from tendyn import _core

from .schema import require_one_per_joint  # noqa: F401 (re-exported: the N+1 refusal)


class RoutingProblem(ValueError):
    """A routing the core cannot use: ``transmission`` (its name), ``key`` (field, or "") and ``problem``."""

    def __init__(self, transmission: str, key: str, problem: str):
        super().__init__(f"transmission {transmission}: {key + ': ' if key else ''}{problem}")
        self.transmission, self.key, self.problem = transmission, key, problem


def routing_matrix(transmissions, n_joints: int) -> np.ndarray:
    """K (m, n) [m] of transmission specs sorted by driven joint: crossed radii at the crossed joints (before or
    after the driven one), driven_radius * reducer_ratio (S0 footnote 1) at the driven joint."""
    K = np.zeros((len(transmissions), n_joints))
    for i, t in enumerate(transmissions):
        for jn, rad in zip(t.crosses, t.crossed_radii):
            K[i, jn - 1] = rad
        K[i, t.joint - 1] = t.driven_radius * t.reducer_ratio
    return K


def antagonistic_min_pretension(t) -> float:
    """Smallest pretension [N] of each cable of an antagonistic pair that keeps both taut up to the motor's peak
    torque: the pair shares the net tension u = C_m / r_m as P + u/2 and P - u/2, so P >= C_peak / (2 r_m)."""
    return t.motor.peak_torque / (2.0 * t.motor_radius)


def virtual_work_residual(model) -> float:
    """Largest relative power mismatch |q̇ᵀτ_J − q̇_mᵀC_m| / (|q̇||τ_J|) of the lossless maps of a core model
    (S0 eq. 5: C_m = R_m K⁻ᵀ τ_J, q̇_m = R_m⁻¹ K q̇), over the unit joint velocities and torques."""
    A = np.asarray(model.motor_from_joint_position).T @ np.asarray(model.motor_from_joint_torque)
    return float(np.max(np.abs(A - np.eye(A.shape[0]))))


def check_transmissions(transmissions, n_joints: int) -> None:
    """Raise :class:`RoutingProblem` naming the transmission when the routing is singular, not power-consistent,
    holds a self-locking reducer outside a serial routing, or an antagonistic pair's pretension is too low."""
    if len(transmissions) != n_joints:
        return  # a device with passive joints keeps S0's square form on its active joints (rigid_body maps)
    K = routing_matrix(transmissions, n_joints)
    structure = _core.routing_structure(K)
    dep = structure["dependent_transmission"]
    if dep >= 0:
        t = transmissions[dep]
        earlier = ", ".join(x.name for x in transmissions[:dep]) or "none"
        if t.driven_radius == 0.0:
            raise RoutingProblem(t.name, "driven_radius", "must be nonzero here (got 0.0): a zero driven radius "
                                 f"makes the routing singular (the row of K of transmission {t.name}, "
                                 f"{np.array2string(K[dep], precision=4)} m, is a combination of the rows before "
                                 f"it: {earlier})")
        raise RoutingProblem(t.name, "", f"the routing is singular: the row of K of transmission {t.name} "
                             f"({np.array2string(K[dep], precision=4)} m) is a combination of the rows of the "
                             f"transmissions before it ({earlier}), so K has no inverse")
    if not structure["serial"]:
        for t in transmissions:
            if t.self_locking:
                raise RoutingProblem(t.name, "reducer_efficiency", f"must be > 0.5 (got {t.reducer_efficiency:g}): "
                                     "self-locking reducers are modelled in serial routings only, and this "
                                     "routing has differentials, negative or zero driven radii")
    model = _core.TransmissionModel({
        "motor_radius": np.array([t.motor_radius for t in transmissions]), "K": K,
        "driven_radius": np.array([t.driven_radius for t in transmissions]),
        "reducer_ratio": np.array([t.reducer_ratio for t in transmissions]),
        "reducer_efficiency": np.array([t.reducer_efficiency for t in transmissions])})
    res = virtual_work_residual(model)
    if not res < 1e-9:
        raise RoutingProblem(transmissions[0].name, "", f"the routing is not power-consistent: q̇ᵀτ_J and "
                             f"q̇_mᵀC_m differ by {res:.3g} (relative); K is too ill-conditioned")
    for t in transmissions:
        if t.antagonistic:
            need = antagonistic_min_pretension(t)
            if t.pretension < need:
                raise RoutingProblem(t.name, "pretension", f"must be >= {need:.6g} N (got {t.pretension:g}): "
                                     "below it a cable of the antagonistic pair goes slack before the motor "
                                     "reaches its peak torque (P >= peak_torque / (2 motor_radius))")


def tendon_model(transmissions, n_joints: int):
    """The core's ``TendonModel`` of N+1 tendons (sorted as the device holds them): K (n + 1, n) [m], motor radii
    [m], tension floors = the tendons' ``pretension`` [N], each tendon's last joint and its branch losses τ0 [N], ν
    [N·s/m] (S0 eq. 12) and β [-] (S0 eq. 11). ValueError (0-based tendon) when the core refuses it."""
    m = len(transmissions)
    tau0, nu, beta = np.zeros((m, n_joints)), np.zeros((m, n_joints)), np.zeros((m, n_joints))
    for i, t in enumerate(transmissions):
        for b, fr in enumerate(t.friction):
            tau0[i, b], nu[i, b], beta[i, b] = fr.tau0, fr.nu, fr.beta
    return _core.TendonModel(routing_matrix(transmissions, n_joints),
                             np.array([t.motor_radius for t in transmissions], float),
                             np.array([t.pretension for t in transmissions], float),
                             np.array([t.last_joint - 1 for t in transmissions], dtype=np.int32), tau0, nu, beta)


def _names(transmissions, idx) -> str:
    return ", ".join(transmissions[i].name for i in idx)


def check_tendons(transmissions, n_joints: int) -> None:
    """Raise :class:`RoutingProblem` naming the tendon (transmission) when an N+1 routing cannot work.

    Checks, in order: every joint wrapped by some tendon; full row rank of Kᵀ (rank n: the tendons reach every
    joint direction; the first tendon whose row adds no direction is named); tension closure (the null vector h
    of Kᵀ, Kᵀh = 0, is > 0 on every tendon: the tendons where it is not are named, they cannot be kept taut);
    virtual work (τᵀq̇ = tᵀℓ̇ for the core's maps τ = Kᵀt and ℓ̇ = Kq̇, and the minimum-norm tensions deliver
    the torques, Kᵀ P = I, to 1e-9); the tension floors (``pretension``) reachable at rest within each motor's
    peak tension peak_torque / motor_radius.
    """
    K = routing_matrix(transmissions, n_joints)
    m, n = K.shape
    for j in range(n):
        if not np.any(K[:, j]):
            raise RoutingProblem("", "", f"joint {j + 1} is wrapped by no tendon: an N+1 routing needs every "
                                 "joint in some tendon's crosses or joint")
    rank, basis = 0, np.zeros((0, n))
    for i in range(m):
        trial = np.vstack([basis, K[i]])
        r = int(np.linalg.matrix_rank(trial, tol=1e-12 * max(1.0, np.abs(K).max())))
        if r > rank:
            rank, basis = r, trial
        elif rank + (m - 1 - i) < n:      # the remaining tendons cannot make up the missing directions
            t = transmissions[i]
            raise RoutingProblem(t.name, "", f"the tendons do not reach every joint direction (Kᵀ has rank < {n}, "
                                 f"full row rank needed): the row of K of tendon {t.name} "
                                 f"({np.array2string(K[i], precision=4)} m) is a combination of the rows of "
                                 f"{_names(transmissions, range(i)) or 'none'}")
    h = np.linalg.svd(K.T)[2][-1]          # the null vector of Kᵀ (rank n, m = n + 1: one); numpy, no scipy
    if h.sum() < 0:
        h = -h
    h = h / np.abs(h).max()
    bad = [i for i in range(m) if not h[i] > 1e-9]
    if bad:
        t = transmissions[bad[0]]
        raise RoutingProblem(t.name, "", "no tension closure: the only tensions that load no joint are multiples of "
                             f"h = {np.array2string(h, precision=4)} (Kᵀh = 0, tendons in the order "
                             f"{_names(transmissions, range(m))}), which is not > 0 on tendon(s) "
                             f"{_names(transmissions, bad)}: no pretension keeps every tendon taut (reverse the "
                             f"winding of {t.name} on a joint, or route it over other joints)")
    try:
        model = tendon_model(transmissions, n)
    except ValueError as exc:    # the core's own rank/closure test disagrees with the one above: report it as is
        raise RoutingProblem(transmissions[0].name, "", str(exc)) from None
    res = tendon_virtual_work_residual(model)
    if not res < 1e-9:
        raise RoutingProblem(transmissions[0].name, "", f"the routing is not power-consistent: τᵀq̇ and tᵀℓ̇ "
                             f"differ by {res:.3g} (relative), or the minimum-norm tensions miss the torques; "
                             f"Kᵀ is too ill-conditioned (condition {model.condition:.3g})")
    h = np.asarray(model.null_vector)
    floors = np.array([t.pretension for t in transmissions])
    lam = float(np.max(floors / h))
    for i, t in enumerate(transmissions):
        peak = t.motor.peak_torque / t.motor_radius
        if lam * h[i] > peak * (1 + 1e-12):
            raise RoutingProblem(t.name, "pretension", f"the tendons' floors cannot be held at rest: keeping every "
                                 f"tendon at or above its pretension needs the internal tension {lam:.6g} N · h, "
                                 f"i.e. {lam * h[i]:.6g} N on tendon {t.name}, above its motor's peak tension "
                                 f"peak_torque / motor_radius = {peak:.6g} N")


def tendon_virtual_work_residual(model) -> float:
    """Largest relative mismatch of the N+1 core maps over unit vectors: |τᵀq̇ − tᵀℓ̇| with τ = Kᵀt and
    ℓ̇ = Kq̇ (virtual work), |KᵀP − I| (the minimum-norm tensions deliver the torques) and |Kᵀh| (h loads no
    joint), each relative to the size of K."""
    n, m = model.n, model.m
    speeds = np.column_stack([np.asarray(_core.tendon_velocity(model, np.eye(n)[j])) for j in range(n)])   # (m, n)
    torques = np.column_stack([np.asarray(_core.tendon_joint_torque(model, np.eye(m)[i])) for i in range(m)])  # (n, m)
    scale = float(np.abs(speeds).max())
    K = np.asarray(model.K)
    P = np.asarray(model.tension_from_torque)
    h = np.asarray(model.null_vector)
    return max(float(np.abs(torques.T - speeds).max()) / scale,
               float(np.abs(K.T @ P - np.eye(n)).max()),
               float(np.abs(K.T @ h).max()) / scale)


@dataclass(frozen=True)
class TendonCoupling:
    """Result of :func:`tendon_coupling`.

    rank : rank of K (full row rank of the joint map Kᵀ is rank = n)
    null_space : (m, m - rank) basis of the tensions that load no joint (Kᵀ h = 0)
    closure : True when some h in that space is > 0 on every cable (the cables can all be kept taut)
    pattern : (m,) the positive internal tension pattern h, max 1 (None without closure)
    min_pretension : smallest scale P [N] of P·h that keeps every tension >= 0 for every joint torque in the
        box (None without closure or without a box)
    """

    rank: int
    null_space: np.ndarray
    closure: bool
    pattern: np.ndarray | None
    min_pretension: float | None


def tendon_coupling(K, torque_limits=None) -> TendonCoupling:
    """Analyse m cables on n joints (m > n: N+1 when m = n + 1, 2N with a pair per joint).

    Parameters
    ----------
    K : (m, n) [m], row i = cable i: signed radii of the joints it wraps (cable length change = K q)
    torque_limits : (n,) [N m], the box |τ_j| <= limit_j of joint torques the cables must deliver taut

    Tensions t >= 0 (cables only pull) give τ = Kᵀ t; with Kᵀ of full row rank, t = pinv(Kᵀ) τ + Σ λ_k h_k.
    Closure needs an internal pattern h > 0 (Kᵀ h = 0); the pattern is the null vector for N+1 and the sum of
    the pairs' null vectors for 2N (found by a linear programme in general). The minimum pretension is the
    largest, over the box's vertices (t is linear in τ, the bound convex), of max_i (−t_p,i / h_i).
    """
    from scipy.linalg import null_space
    from scipy.optimize import linprog

    K = np.asarray(K, dtype=float)
    m, n = K.shape
    rank = int(np.linalg.matrix_rank(K))
    N = null_space(K.T)
    pattern = None
    if N.shape[1] > 0 and rank == n:
        # max s subject to h = N c, h_i >= s, h_i <= 1: closure when s > 0
        k = N.shape[1]
        c = np.zeros(k + 1); c[-1] = -1.0
        A = np.vstack([np.hstack([-N, np.ones((m, 1))]), np.hstack([N, np.zeros((m, 1))])])
        b = np.concatenate([np.zeros(m), np.ones(m)])
        res = linprog(c, A_ub=A, b_ub=b, bounds=[(None, None)] * k + [(None, 1.0)])
        if res.success and -res.fun > 1e-9:
            h = N @ res.x[:k]
            pattern = h / h.max()
    min_p = None
    if pattern is not None and torque_limits is not None:
        lim = np.asarray(torque_limits, dtype=float)
        P = np.linalg.pinv(K.T)
        worst = 0.0
        for signs in itertools.product((-1.0, 1.0), repeat=n):
            tp = P @ (lim * np.array(signs))
            worst = max(worst, float(np.max(-tp / pattern)))
        min_p = worst
    return TendonCoupling(rank=rank, null_space=N, closure=pattern is not None, pattern=pattern,
                          min_pretension=min_p)


class NotSeparable(ValueError):
    """The S0 identification or decomposition asked of a routing whose losses it cannot separate."""


def coupled_transmissions(device) -> list[list[str]]:
    """Names of the transmissions of each coupled block of K (size > 1: a differential or a zero diagonal),
    and of each transmission whose driven radius is not positive; [] for a serial routing (S0's)."""
    trans = device.transmissions
    arr = device.routing_arrays()
    K = arr["K"]
    if K.shape[0] != K.shape[1]:
        return []
    structure = _core.routing_structure(K)
    if structure["serial"]:
        return []
    begin, end = np.asarray(structure["block_begin"]), np.asarray(structure["block_end"])
    groups, seen = [], set()
    for i in range(len(trans)):
        if begin[i] in seen:
            continue
        if end[i] > begin[i] or K[i, i] <= 0.0:
            seen.add(begin[i])
            groups.append([trans[k].name for k in range(begin[i], end[i] + 1)])
    return groups


def require_separable(device, what: str) -> None:
    """Refuse the S0 identification / decomposition (S0 eqs. 13-21) on a routing that is not serial.

    What the paper's method cannot separate: it reads the losses of transmission i from motor i's torque in an
    isolated move (S0 eq. 16: every branch of that one cable slides with the motor rim, k' = r_m). In a
    differential the cables of a block share joints: holding the other joints (S2) moves the partner motor too
    and leaves the branches past the driven joint at rest (k' = 0: their losses never appear); holding the other
    motors (S1) moves the partner's cable as well, whose losses reach motor i through the shared joints. Motor
    i's torque then mixes the losses of several cables, and the power balance (S0 eqs. 17-19) has more unknowns
    than tests. A serial block (a transmission alone in its block, positive driven radius) is still separable,
    but the commands take the whole device: use the device file's losses (Compensator.from_device,
    ``tendyn export transmission``) for such routings.
    """
    groups = coupled_transmissions(device)
    if groups:
        desc = "; ".join(", ".join(g) for g in groups)
        raise NotSeparable(
            f"{device.name}: {what} needs a serial routing (S0 eqs. 13-21 separate the losses of one cable per "
            f"motor): transmissions {desc} are coupled (a differential, a negative or zero driven radius), so "
            "an isolated move mixes the losses of several cables; use the device file's losses "
            "(docs/compensator.md, 'General routings')")
