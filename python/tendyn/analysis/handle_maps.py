"""What the operator feels at the handle of a cable-driven (or geared) device: apparent mass, viscous and dry
friction over the joint workspace.

The device's motors sit behind a motor-from-joint matrix G (q̇_m = G q̇; ``SerialDevice.motor_joint_matrix``):
G = R_m⁻¹ K for ``[[transmissions]]`` (S0 eqs. 1–2, corrected: ERRATA, R_m q_m = K q), diag(N)(I + coupling)
for ``[[actuators]]``. Motor torques y reach the joints as τ = Gᵀ y (virtual work, ERRATA eq. 5). Per motor i
the friction is the compensator's law, S0 eq. 13 (corrected: ERRATA), C_m,i = C_m0,i sgn(q̇_m,i) + ν_i q̇_m,i.

In the joint space (active coordinates) the device then reads

    A(q) = Lᵀ M_tree(q) L + Gᵀ diag(I_r) G     links + rotors reflected through the transmission [kg·m²]
                                              (½ q̇_mᵀ diag(I_r) q̇_m = ½ q̇ᵀ Gᵀ diag(I_r) G q̇)
    B_J  = Gᵀ diag(ν) G                        viscous [N·m·s/rad]  (power Σ ν_i q̇_m,i² = q̇ᵀ B_J q̇)
    P_c  = Σ_i C_m0,i |(G q̇)_i|                dry-friction power [W]

and the handle point X has the Jacobian J = ∂X/∂q (3 × n, operator frame, :class:`HandlePoint`). J need be
neither square nor of rank 3: a planar arm moves its handle in a plane, a 4-joint arm (L-EXOS) has one
redundant joint. With U_r the r directions the handle can move (the left singular vectors of J with
σ > 10⁻⁶ σ_max) and J_r = U_rᵀ J (r × n, full row rank), each quantity at the handle is the least the
joints can do for a handle motion v ∈ ℝʳ (a free redundant joint follows the motion that costs least):

    vᵀ Λ v   = min_{J_r q̇ = v} q̇ᵀ A q̇,        Λ = (J_r A⁻¹ J_rᵀ)⁻¹         apparent mass [kg]
    vᵀ B v   = min_{J_r q̇ = v} q̇ᵀ B_J q̇,      B = (J_r B_J⁻¹ J_rᵀ)⁻¹       viscous friction [N·s/m]
    h(u)     = min_{J_r q̇ = u} Σ_i C_m0,i |(G q̇)_i|                        dry friction along u [N]

(for a square J these are J⁻ᵀ A J⁻¹, J⁻ᵀ B_J J⁻¹ and Σ_i C_m0,i |(G J⁻¹ u)_i|). Λ is the Gauss minimum: a force
F at rest gives Ẍ = J_r A⁻¹ J_rᵀ F = Λ⁻¹ F (gravity apart). h(u) is virtual work: moving the handle along the
unit u at speed s the operator supplies F·u s = P_c. By LP duality h is the support function of the set of
handle forces the dry friction can hold, P = {F ∈ ℝʳ : |(G⁻ᵀ J_rᵀ F)_i| ≤ C_m0,i} (G square: one motor per
active joint), so its largest value over the directions is the largest ‖F‖ over the vertices of P and its
smallest the distance to P's nearest face, min_i C_m0,i / ‖row_i(G⁻ᵀ J_rᵀ)‖.

Where the values come from (``sources`` of the result):

* inertia — the device file (links, rotor inertia of each ``[transmissions.motor]`` / actuator) or any
  ``mass_matrix(q)`` given (``tendyn maps`` builds it from an identified PARAMS.json through
  ``tendyn.ident.IdentModel.mass_matrix``, rotor terms IA/IAm included);
* friction — identified (C_m0, ν) per transmission (FRICTION.json, ``tendyn.friction/1``), or the device
  file's loss model reduced to the same two numbers through the core's statics
  (:func:`equivalent_motor_friction`: the motor torque that moves one transmission alone at ±v with no joint
  torque, the zero-load values of S0 eqs. 18–19 with β, bearings and reducers included) or, for actuators, their
  ``coulomb_motor``/``viscous_motor``;
* stiffness — schema 1 gives a cable device no cable stiffness; the maps say so (``stiffness: null``).

The poses are a grid in the active joints' limits (each range less 2 % at both ends; ±π for a joint without
limits), ``points`` per joint, at most :data:`POSE_BUDGET` poses by default; poses where J_r is ill conditioned
(cond > :data:`MAX_CONDITION`) are counted but left out of the extremes (the mass there grows as 1/σ²).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import scipy.linalg

from tendyn.analysis.handle_point import HandlePoint
from tendyn.device import compile_device
from tendyn.protocols import DEFAULT_SPEEDS
from tendyn.results import Result, format_table

__all__ = ["HandleModel", "HandlePose", "HandleMaps", "handle_maps", "equivalent_motor_friction",
           "friction_polytope", "reduced_quadratic", "POSE_BUDGET", "MAX_CONDITION", "EQUIVALENT_SPEEDS"]

POSE_BUDGET = 2000
"""Default largest number of grid poses (points per joint = ⌊budget^(1/n)⌋, within 2…21)."""
MAX_POINTS = 21
LIMIT_MARGIN = 0.02
"""Fraction of each joint range left out at both ends of the grid."""
MAX_CONDITION = 100.0
"""Poses whose J_r has σ_max/σ_min above this are near a singularity: counted, not in the extremes."""
RANK_TOL = 1e-6
"""Singular values of J below this fraction of the largest are directions the handle does not move."""
EQUIVALENT_SPEEDS = DEFAULT_SPEEDS   # the speeds of a planned constant-velocity test (tendyn.protocols)
"""Motor speeds [rad/s] of the equivalent friction of a device file (the default speeds of
``tendyn plan constant-velocity``, so the file's values compare with an identification's)."""
AXES = ("x", "y", "z")


# --------------------------------------------------------------------------------------------------------
# the friction of a device file, per transmission
# --------------------------------------------------------------------------------------------------------

def equivalent_motor_friction(transmission, speeds: Sequence[float] = EQUIVALENT_SPEEDS) -> tuple[np.ndarray, np.ndarray]:
    """(C_m0 [N·m], ν [N·m·s/rad]) per transmission of a device file's loss model, motor side.

    For each transmission i alone (S2 isolated move: only joint i turns, q̇_i = r_m,i q̇_m,i / K_ii) the core's
    statics (``Transmission.feedforward``, every loss: τ_0, ν, β, bearings, reducer efficiency) give the motor
    torque with no joint torque at +v and −v; half their difference at each speed of ``speeds`` [rad/s] is fitted
    by C_m0 + ν v (least squares) — the zero-load values of S0 eqs. 18–19 (ERRATA: ν = Σ_j ν_j k'², C_m0 =
    Σ_j τ_0,j |k'|, k' = r_m), with the β/bearing/reducer losses the pretension alone causes.
    """
    mats = transmission.matrices()
    K, r_m = mats["K"], np.diag(mats["R_m"])
    n = transmission.n
    v = np.asarray(speeds, float)
    W = np.column_stack([np.ones_like(v), v])
    coulomb, viscous = np.zeros(n), np.zeros(n)
    for i in range(n):
        half = []
        for s in v:
            qd = np.zeros(n)
            qd[i] = r_m[i] * s / K[i, i]
            up = transmission.feedforward(np.zeros(n), qd).torque_motor[i]
            down = transmission.feedforward(np.zeros(n), -qd).torque_motor[i]
            half.append(0.5 * (up - down))
        (coulomb[i], viscous[i]), *_ = np.linalg.lstsq(W, np.asarray(half), rcond=None)
    return coulomb, viscous


# --------------------------------------------------------------------------------------------------------
# the two reductions to the handle
# --------------------------------------------------------------------------------------------------------

def reduced_quadratic(M, Jr) -> np.ndarray:
    """X (r × r) with vᵀ X v = min over J_r q̇ = v of q̇ᵀ M q̇ (M symmetric ≥ 0, J_r full row rank).

    q̇ = J_r⁺ v + N z (N a basis of ker J_r); the minimum over z leaves X = Pᵀ (M − M N S⁺ Nᵀ M) P, P = J_r⁺,
    S = Nᵀ M N; for M > 0 it equals (J_r M⁻¹ J_rᵀ)⁻¹ and for a square J_r, J_r⁻ᵀ M J_r⁻¹."""
    M = np.asarray(M, float)
    P = np.linalg.pinv(Jr)
    N = scipy.linalg.null_space(Jr)
    if N.shape[1]:
        MN = M @ N
        M = M - MN @ np.linalg.pinv(N.T @ MN) @ MN.T
    X = P.T @ M @ P
    return 0.5 * (X + X.T)


def minimising_velocity(M, Jr, v) -> np.ndarray:
    """The joint velocity q̇ [rad/s] of :func:`reduced_quadratic`'s minimum for the handle velocity v."""
    P = np.linalg.pinv(Jr)
    N = scipy.linalg.null_space(Jr)
    q = P @ np.asarray(v, float)
    if N.shape[1]:
        q = q - N @ np.linalg.pinv(N.T @ M @ N) @ (N.T @ M @ q)
    return q


def friction_polytope(A, C) -> np.ndarray:
    """Vertices (k, r) of P = {F : |A F| ≤ C} (A (m, r) of rank r, C (m,) ≥ 0): each choice of r independent
    rows held at ±C, kept where every other row holds too. m ≤ 12 keeps this within a few thousand solves."""
    A, C = np.asarray(A, float), np.asarray(C, float)
    m, r = A.shape
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=r)))
    scale = np.max(np.abs(A)) or 1.0
    out = []
    for rows in itertools.combinations(range(m), r):
        As = A[list(rows)]
        if abs(np.linalg.det(As / scale)) < 1e-10:
            continue
        F = np.linalg.solve(As, (signs * C[list(rows)]).T).T          # (2^r, r)
        ok = np.all(np.abs(F @ A.T) <= C * (1 + 1e-9) + 1e-12 * max(1.0, C.max()), axis=1)
        out.append(F[ok])
    return np.vstack(out) if out else np.zeros((0, r))


# --------------------------------------------------------------------------------------------------------
# the model at one pose
# --------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class HandlePose:
    """What the handle shows at one pose.

    q : (n,) active joints [rad]; position : (3,) handle [m], operator frame; J : (3, n) [m/rad];
    basis : (3, r) the directions the handle moves (U_r), operator frame; cond : σ_max/σ_min of J_r [-];
    mass : (r, r) Λ [kg]; viscous : (r, r) B [N·s/m]; rows : (m, r) G⁻ᵀ J_rᵀ [1/m], P = {F : |rows F| ≤ C_m0};
    coulomb_motor : (m,) C_m0 [N·m]; vertices : (k, r) of P [N] (in the basis).
    """

    q: np.ndarray
    position: np.ndarray
    J: np.ndarray
    basis: np.ndarray
    cond: float
    mass: np.ndarray
    viscous: np.ndarray
    rows: np.ndarray
    coulomb_motor: np.ndarray
    vertices: np.ndarray

    @property
    def task_dimension(self) -> int:
        return self.basis.shape[1]

    def apparent_mass(self) -> np.ndarray:
        """Principal apparent masses [kg], descending (eigenvalues of Λ)."""
        return np.sort(np.linalg.eigvalsh(self.mass))[::-1]

    def viscous_principal(self) -> np.ndarray:
        """Principal viscous frictions [N·s/m], descending (eigenvalues of B)."""
        return np.sort(np.linalg.eigvalsh(self.viscous))[::-1]

    def mass_matrix_3d(self) -> np.ndarray:
        """Λ in the operator frame, U_r Λ U_rᵀ (3 × 3, rank r) [kg]."""
        return self.basis @ self.mass @ self.basis.T

    def viscous_matrix_3d(self) -> np.ndarray:
        """B in the operator frame, U_r B U_rᵀ (3 × 3, rank r) [N·s/m]."""
        return self.basis @ self.viscous @ self.basis.T

    def dry_friction(self, u) -> float:
        """h(u) [N]: the force along the unit u (operator frame) that moves the handle along u against the dry
        friction; NaN when u is not a direction the handle moves (more than 10⁻⁶ outside its span)."""
        u = np.asarray(u, float)
        u = u / np.linalg.norm(u)
        w = self.basis.T @ u
        if np.linalg.norm(self.basis @ w - u) > 1e-6:
            return float("nan")
        return float(np.max(self.vertices @ w)) if len(self.vertices) else 0.0

    def _signed(self, w) -> np.ndarray:
        u = self.basis @ w
        return u * (1 if u[np.argmax(np.abs(u))] > 0 else -1)

    def dry_friction_min(self) -> tuple[float, np.ndarray]:
        """(min over u of h(u) [N], that u in the operator frame): P's nearest face, min_i C_m0,i / ‖rows_i‖
        (a ball of radius ρ lies in P iff ρ ‖rows_i‖ ≤ C_m0,i for every i, and iff ρ ≤ h(u) for every u)."""
        norms = np.linalg.norm(self.rows, axis=1)
        live = np.flatnonzero(norms > 1e-12 * max(1.0, norms.max()))
        if not len(live):
            return float("inf"), self.basis[:, 0]
        k = live[int(np.argmin(self.coulomb_motor[live] / norms[live]))]
        return float(self.coulomb_motor[k] / norms[k]), self._signed(self.rows[k] / norms[k])

    def dry_friction_max(self) -> tuple[float, np.ndarray]:
        """(max over u of h(u) [N], that u in the operator frame): the vertex of P farthest from 0."""
        if not len(self.vertices):
            return 0.0, self.basis[:, 0]
        norms = np.linalg.norm(self.vertices, axis=1)
        k = int(np.argmax(norms))
        if norms[k] == 0:
            return 0.0, self.basis[:, 0]
        return float(norms[k]), self._signed(self.vertices[k] / norms[k])


class HandleModel:
    """Joint-space inertia and friction of a serial device with ``[[transmissions]]`` or ``[[actuators]]``, and
    their image at the handle (module docstring).

    Parameters
    ----------
    device : Device or CompiledDevice
    coulomb_motor, viscous_motor : (m,) identified C_m0 [N·m] and ν [N·m·s/rad] per motor (FRICTION.json's
        arrays); None: the device file's (:func:`equivalent_motor_friction`, or the actuators' priors)
    mass_matrix : callable q (n,) [rad] → A (n, n) [kg·m²], rotors included (identified); None: the device file's
    sources : {"inertia": text, "friction": text} describing where given values come from
    """

    def __init__(self, device, *, coulomb_motor=None, viscous_motor=None,
                 mass_matrix: Callable[[np.ndarray], np.ndarray] | None = None, sources: dict | None = None):
        self.compiled = compile_device(device)
        dev = self.compiled.device
        if dev.kind != "serial" or not (dev.transmissions or dev.actuators):
            raise ValueError(f"{dev.name}: the handle maps need [[transmissions]] or [[actuators]] "
                             "(capstan [[drives]]: tendyn.analysis.operational)")
        self.device = dev
        self.handle = HandlePoint(self.compiled)
        self.G = np.asarray(dev.motor_joint_matrix(), float)
        m, n = self.G.shape
        if m != n or np.linalg.matrix_rank(self.G) < n:
            raise ValueError(f"{dev.name}: the maps need one motor per active joint and an invertible "
                             f"motor-from-joint matrix (G is {m} × {n})")
        motors = [t.motor for t in dev.transmissions] if dev.transmissions else list(dev.actuators)
        self.rotor_inertia = np.array([mo.rotor_inertia for mo in motors], float)
        src = dict(sources or {})
        if (coulomb_motor is None) != (viscous_motor is None):
            raise ValueError("coulomb_motor and viscous_motor come together (FRICTION.json's two arrays)")
        if coulomb_motor is None:
            if dev.transmissions:
                coulomb_motor, viscous_motor = equivalent_motor_friction(self.compiled.transmission)
                src.setdefault("friction", "device file: loss model reduced by the core's statics at zero load "
                                           f"(S0 eqs. 18-19, motor speeds {', '.join(f'{v:g}' for v in EQUIVALENT_SPEEDS)} rad/s)")
            else:
                coulomb_motor = [a.coulomb_motor for a in dev.actuators]
                viscous_motor = [a.viscous_motor for a in dev.actuators]
                src.setdefault("friction", "device file: the actuators' coulomb_motor and viscous_motor")
        self.coulomb_motor = np.asarray(coulomb_motor, float)
        self.viscous_motor = np.asarray(viscous_motor, float)
        for name, a in (("coulomb_motor", self.coulomb_motor), ("viscous_motor", self.viscous_motor)):
            if a.shape != (m,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"{name}: {m} finite values >= 0 expected (one per motor; got {a.tolist()})")
        self._mass_matrix = mass_matrix
        src.setdefault("inertia", "device file: links and rotor_inertia of each motor" if mass_matrix is None
                       else "given mass matrix")
        self.sources = src
        self._pd = self.compiled.pinocchio_data()
        # polytope rows need G⁻ᵀ: computed once (G is constant)
        self._G_inv_T = np.linalg.inv(self.G).T

    @property
    def n(self) -> int:
        return self.G.shape[1]

    def joint_mass_matrix(self, q) -> np.ndarray:
        """A(q) [kg·m²], active coordinates: links (Lᵀ M_tree L) plus rotors Gᵀ diag(I_r) G, or the given one."""
        if self._mass_matrix is not None:
            A = np.asarray(self._mass_matrix(np.asarray(q, float)), float)
            return 0.5 * (A + A.T)
        from tendyn.device.closed_loop import active_mass_matrix

        h = self.handle
        A = active_mass_matrix(self.compiled.pinocchio_model, h.L, h.c, q, self._pd)
        return A + self.G.T @ np.diag(self.rotor_inertia) @ self.G

    def joint_viscous_matrix(self) -> np.ndarray:
        """B_J = Gᵀ diag(ν) G [N·m·s/rad]."""
        return self.G.T @ np.diag(self.viscous_motor) @ self.G

    def task(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(J (3, n), U_r (3, r), J_r (r, n), cond(J_r)) at q."""
        J = self.handle.jacobian(q)
        U, s, _ = np.linalg.svd(J)
        r = int(np.sum(s > RANK_TOL * s[0])) if s[0] > 0 else 0
        if r == 0:
            raise ValueError(f"{self.device.name}: the handle does not move at q = {list(q)}")
        Ur = U[:, :r]
        return J, Ur, Ur.T @ J, float(s[0] / s[r - 1])

    def at(self, q) -> HandlePose:
        """Λ, B and the dry-friction set at active joints q [rad]."""
        q = np.asarray(q, float)
        J, Ur, Jr, cond = self.task(q)
        A = self.joint_mass_matrix(q)
        rows = self._G_inv_T @ Jr.T                               # (m, r): |rows F| ≤ C_m0 holds F
        return HandlePose(q, self.handle.position(q), J, Ur, cond, reduced_quadratic(A, Jr),
                          reduced_quadratic(self.joint_viscous_matrix(), Jr), rows, self.coulomb_motor,
                          friction_polytope(rows, self.coulomb_motor))

    def joint_velocity(self, q, v, which: str = "mass") -> np.ndarray:
        """The joint velocity [rad/s] that moves the handle at v (r,) [m/s] (in the pose's basis) at least kinetic
        energy (``"mass"``) or viscous power (``"viscous"``)."""
        _, _, Jr, _ = self.task(q)
        M = self.joint_mass_matrix(q) if which == "mass" else self.joint_viscous_matrix()
        return minimising_velocity(M, Jr, v)


# --------------------------------------------------------------------------------------------------------
# over the workspace
# --------------------------------------------------------------------------------------------------------

def joint_grid(handle: HandlePoint, points: int | None = None, budget: int = POSE_BUDGET,
               margin: float = LIMIT_MARGIN) -> tuple[np.ndarray, int]:
    """(poses (k, n) [rad] inside every tree joint's limits, points per joint) — a grid on the active joints'
    ranges less ``margin`` of each at both ends (±π where the file gives no limit)."""
    lo, hi = handle.active_limits()
    lo = np.where(np.isfinite(lo), lo, -math.pi)
    hi = np.where(np.isfinite(hi), hi, math.pi)
    span = hi - lo
    lo, hi = lo + margin * span, hi - margin * span
    n = len(lo)
    if points is None:
        points = int(min(MAX_POINTS, max(2, math.floor(budget ** (1.0 / n) + 1e-9))))
    axes = [np.linspace(a, b, points) for a, b in zip(lo, hi)]
    Q = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, n)
    keep = np.array([handle.within_limits(q) for q in Q], bool)
    return Q[keep], points


@dataclass(eq=False)
class HandleMaps(Result):
    """Apparent mass, viscous and dry friction at the handle over a joint grid (:func:`handle_maps`).

    Attributes
    ----------
    device : name; sources : {"inertia", "friction"} (text); task_dimension : r, the directions the handle moves
    q : (k, n) poses [rad]; position : (k, 3) handle [m], operator frame; cond : (k,) σ_max/σ_min of J_r
    usable : (k,) cond ≤ ``max_condition`` (the extremes are over these; an identified A that is not positive
        definite shows as a smallest apparent mass ≤ 0, counted in ``mass_not_positive_definite_poses``)
    mass : (k, r) principal apparent masses [kg], descending; viscous : (k, r) principal viscous [N·s/m]
    dry_max, dry_min : (k,) largest and smallest dry friction over the directions [N]
    dry_axes : (k, 3) dry friction along the operator axes x, y, z [N] (NaN where the handle cannot move so)
    rotor_inertia : (m,) [kg·m²]; coulomb_motor, viscous_motor : (m,) the friction used [N·m], [N·m·s/rad]
    reference : dict, the best-conditioned pose in detail; points : per joint
    """

    device: str
    sources: dict
    task_dimension: int
    q: np.ndarray
    position: np.ndarray
    cond: np.ndarray
    usable: np.ndarray
    mass: np.ndarray
    viscous: np.ndarray
    dry_max: np.ndarray
    dry_min: np.ndarray
    dry_axes: np.ndarray
    rotor_inertia: np.ndarray
    coulomb_motor: np.ndarray
    viscous_motor: np.ndarray
    reference: dict
    points: int
    max_condition: float = MAX_CONDITION
    _panels = 4
    _figsize = (4.2, 3.6)

    @property
    def figures(self) -> dict:
        """{"handle_maps": self} (one figure, four panels)."""
        return {"handle_maps": self}

    def _plane(self) -> tuple[int, int]:
        ext = np.ptp(self.position[self.usable], axis=0) if self.usable.any() else np.ones(3)
        a, b = sorted(np.argsort(ext)[::-1][:2])
        return int(a), int(b)

    reading = ('Each dot is one reachable handle pose seen from above or aside (axes in mm); its colour is the '
               "quantity in the colour bar's label, so hot spots are where the operator feels most.")

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        a, b = self._plane()
        sel = self.usable
        p = 1e3 * self.position[sel]
        panels = ((self.mass[sel, 0], "largest apparent mass [kg]"),
                  (self.mass[sel, -1], "smallest apparent mass [kg]"),
                  (self.dry_max[sel], "largest dry friction [N]"),
                  (self.viscous[sel, 0], "largest viscous friction [N·s/m]"))
        order = np.argsort(p[:, 3 - a - b]) if p.shape[0] else np.zeros(0, int)   # far side drawn first
        from matplotlib.colors import LogNorm

        for axis, (values, label) in zip(axes, panels):
            v = values[order]
            spread = len(v) and np.all(v > 0) and v.max() > 10 * v.min()      # near singularities: a log scale
            sc = axis.scatter(p[order, a], p[order, b], c=v, s=10, cmap="viridis",
                              norm=LogNorm(v.min(), v.max()) if spread else None)
            axis.figure.colorbar(sc, ax=axis, label=label)
            axis.set_xlabel(f"handle {AXES[a]} [mm]")
            axis.set_ylabel(f"handle {AXES[b]} [mm]")
            axis.set_aspect("equal", adjustable="datalim")
            axis.grid(alpha=0.3)
            axis.set_title(label.split(" [")[0], fontsize=9)
        axes[0].figure.suptitle(f"{self.device}: at the handle over {int(sel.sum())} poses (operator frame, "
                                f"z against gravity)", fontsize=9)

    def _u(self, a):
        return a[self.usable]

    def to_dict(self) -> dict:
        u = self.usable
        return {
            "device": self.device,
            "kind": "handle",
            "sources": dict(self.sources),
            "task_dimension": self.task_dimension,
            "frame": "operator: z against gravity, x the horizontal part of base x0, y = z × x",
            "max_apparent_mass_kg": float(np.max(self._u(self.mass)[:, 0])),
            "min_apparent_mass_kg": float(np.min(self._u(self.mass)[:, -1])),
            "max_viscous_N_s_per_m": float(np.max(self._u(self.viscous)[:, 0])),
            "min_viscous_N_s_per_m": float(np.min(self._u(self.viscous)[:, -1])),
            "max_dry_friction_N": float(np.max(self._u(self.dry_max))),
            "min_dry_friction_N": float(np.min(self._u(self.dry_min))),
            "median": {"largest_apparent_mass_kg": float(np.median(self._u(self.mass)[:, 0])),
                       "largest_viscous_N_s_per_m": float(np.median(self._u(self.viscous)[:, 0])),
                       "largest_dry_friction_N": float(np.median(self._u(self.dry_max)))},
            "mass_not_positive_definite_poses": int(np.sum(self._u(self.mass)[:, -1] <= 0)),
            "stiffness": None,
            "stiffness_note": "the device file gives no cable or joint stiffness (schema 1): the maps have none",
            "rotor_inertia_kg_m2": [float(v) for v in self.rotor_inertia],
            "coulomb_motor_N_m": [float(v) for v in self.coulomb_motor],
            "viscous_motor_N_m_s_per_rad": [float(v) for v in self.viscous_motor],
            "grid": {"points_per_joint": self.points, "poses": int(u.size), "usable": int(u.sum()),
                     "max_condition": self.max_condition,
                     "joint_margin_fraction": LIMIT_MARGIN},
            "reference_pose": self.reference,
        }

    def table(self) -> str:
        d = self.to_dict()
        ref = self.reference
        rows = [
            ("apparent mass, largest / smallest (grid) [kg]",
             f"{d['max_apparent_mass_kg']:.4g} / {d['min_apparent_mass_kg']:.4g}"),
            ("largest apparent mass / dry / viscous friction, median over the poses",
             f"{d['median']['largest_apparent_mass_kg']:.4g} kg / {d['median']['largest_dry_friction_N']:.4g} N / "
             f"{d['median']['largest_viscous_N_s_per_m']:.4g} N·s/m"),
            ("apparent mass, principal (reference pose) [kg]", ", ".join(f"{v:.4g}" for v in ref["apparent_mass_kg"])),
            ("viscous friction, largest / smallest (grid) [N·s/m]",
             f"{d['max_viscous_N_s_per_m']:.4g} / {d['min_viscous_N_s_per_m']:.4g}"),
            ("viscous friction, principal (reference pose) [N·s/m]",
             ", ".join(f"{v:.4g}" for v in ref["viscous_N_s_per_m"])),
            ("dry friction, largest / smallest (grid) [N]",
             f"{d['max_dry_friction_N']:.4g} / {d['min_dry_friction_N']:.4g}"),
            ("dry friction along x, y, z (reference pose) [N]",
             ", ".join("–" if v is None else f"{v:.4g}" for v in ref["dry_friction_along_axes_N"])),
            ("stiffness", "none in the device file"),
        ]
        text = format_table(("quantity", "value"), rows,
                            title=f"{self.device}: at the handle, {d['grid']['usable']} of {d['grid']['poses']} "
                                  f"poses ({self.points} per joint, cond(J) ≤ {self.max_condition:g}), "
                                  f"{self.task_dimension} handle directions")
        q = ", ".join(f"{v:.4g}" for v in ref["q_rad"])
        motors = format_table(("motor", "I_r [kg·m²]", "C_m0 [N·m]", "ν [N·m·s/rad]"),
                              [(i + 1, *vals) for i, vals in enumerate(zip(self.rotor_inertia, self.coulomb_motor,
                                                                           self.viscous_motor))],
                              title="per motor")
        return (text + f"\nreference pose (best conditioned) q = ({q}) rad, handle at "
                f"{', '.join(f'{1e3 * v:.1f}' for v in ref['handle_position_m'])} mm\n"
                f"inertia: {self.sources['inertia']}\nfriction: {self.sources['friction']}\n\n" + motors)


def _pose_dict(p: HandlePose) -> dict:
    fmax, umax = p.dry_friction_max()
    fmin, umin = p.dry_friction_min()
    lam = p.apparent_mass()
    w, V = np.linalg.eigh(p.mass)
    heavy = p.basis @ V[:, int(np.argmax(w))]
    heavy = heavy * (1 if heavy[np.argmax(np.abs(heavy))] > 0 else -1)
    along = [p.dry_friction(e) for e in np.eye(3)]
    return {"q_rad": [float(v) for v in p.q], "handle_position_m": [float(v) for v in p.position],
            "jacobian_condition": p.cond, "directions": [[float(v) for v in col] for col in p.basis.T],
            "apparent_mass_kg": [float(v) for v in lam], "heaviest_direction": [float(v) for v in heavy],
            "apparent_mass_matrix_kg": np.round(p.mass_matrix_3d(), 12).tolist(),
            "viscous_N_s_per_m": [float(v) for v in p.viscous_principal()],
            "viscous_matrix_N_s_per_m": np.round(p.viscous_matrix_3d(), 12).tolist(),
            "dry_friction_max_N": fmax, "dry_friction_max_direction": [float(v) for v in umax],
            "dry_friction_min_N": fmin, "dry_friction_min_direction": [float(v) for v in umin],
            "dry_friction_along_axes_N": [None if math.isnan(v) else float(v) for v in along]}


def handle_maps(device, *, coulomb_motor=None, viscous_motor=None, mass_matrix=None, sources=None,
                points: int | None = None, budget: int = POSE_BUDGET, max_condition: float = MAX_CONDITION,
                progress=None) -> HandleMaps:
    """Apparent mass, viscous and dry friction at the handle over a grid of the joint limits.

    Parameters
    ----------
    device : Device, CompiledDevice or HandleModel
    coulomb_motor, viscous_motor, mass_matrix, sources : as :class:`HandleModel`
    points : grid points per active joint (default ⌊budget^(1/n)⌋ within 2…21)
    budget : the default grid's largest number of poses
    max_condition : poses with cond(J_r) above it are left out of the extremes
    progress : callable(str) for progress messages (stderr in the command)
    """
    model = device if isinstance(device, HandleModel) else HandleModel(
        device, coulomb_motor=coulomb_motor, viscous_motor=viscous_motor, mass_matrix=mass_matrix, sources=sources)
    Q, points = joint_grid(model.handle, points, budget)
    if not len(Q):
        raise ValueError(f"{model.device.name}: no grid pose inside the joint limits")
    poses = [model.at(q) for q in Q]
    r = max(p.task_dimension for p in poses)
    full = np.array([p.task_dimension == r for p in poses])
    cond = np.array([p.cond for p in poses])
    usable = full & (cond <= max_condition)
    k = len(poses)
    mass, visc = np.full((k, r), np.nan), np.full((k, r), np.nan)
    dmax, dmin, daxes = np.full(k, np.nan), np.full(k, np.nan), np.full((k, 3), np.nan)
    for i, p in enumerate(poses):
        if not full[i]:
            continue
        mass[i], visc[i] = p.apparent_mass(), p.viscous_principal()
        dmax[i], dmin[i] = p.dry_friction_max()[0], p.dry_friction_min()[0]
        daxes[i] = [p.dry_friction(e) for e in np.eye(3)]
    if not usable.any():
        raise ValueError(f"{model.device.name}: no pose of the grid has cond(J) <= {max_condition:g} "
                         f"(the best is {np.min(cond):.3g})")
    if progress:
        progress(f"maps: {int(usable.sum())}/{k} poses usable (cond(J) <= {max_condition:g}), "
                 f"{r} handle directions")
    best = int(np.argmin(np.where(full, cond, np.inf)))
    return HandleMaps(model.device.name, dict(model.sources), r, Q, np.array([p.position for p in poses]), cond,
                      usable, mass, visc, dmax, dmin, daxes, model.rotor_inertia, model.coulomb_motor,
                      model.viscous_motor, _pose_dict(poses[best]), points, max_condition)
