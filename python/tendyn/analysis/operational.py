"""What the operator feels at the handle: apparent mass, friction and stiffness maps (S2 §VII, C41–C45).

In the operational space the branch reads (S2 eq. 18)

    F_op = M_op Ẍ + B_op Ẋ + K_op X + F_cop sign(·) + F_d,

with J = ∂X/∂q_a the handle-point Jacobian in the active coordinates of the closed loop (q_a = q1, q2, q5),

    M_op  = J⁻ᵀ A(q) J⁻¹                    apparent mass [kg]
    B_op  = J⁻ᵀ F_v J⁻¹                     apparent viscous friction [N·s/m]
    K_op  = J⁻ᵀ (N² K_tot) J⁻¹              stiffness [N/m], 1/K_tot = 1/K_T + 1/K_E (S2 eq. 19; K_T and K_E
                                            are motor-side stiffnesses, joint side N² K_tot: ERRATA eq. 19)
    F_cop = J⁻ᵀ F_c                         operational Coulomb friction [N]
    F_d   = J⁻ᵀ (Q(q) + C(q, q̇) q̇ − A(q) J⁻¹ J̇ q̇)   the torque the linear model neglects (S2 eq. 20,
                                            corrected: ERRATA — with Ẍ = J q̈ + J̇ q̇ the printed "− A q̈"
                                            double-counts the inertia already in M_op Ẍ).

Every joint-space term comes from *base parameters* — the identification contract of ``tendyn identify
--json`` (``params``: ``{name, value, stderr, rel_stderr_pct, unit, expression}``) or the twin's true ones
(:func:`true_params`). A base parameter multiplies the regressor column of the first standard parameter of its
``expression`` (the column kept when the others were regrouped into it), so

    Γ(q, q̇, q̈) = Σ_k x̂_k W_k(q, q̇, q̈)     (S2 eq. 2; W = Lᵀ Y_tree plus the drive columns, S2 eq. 12),

and A(q) e_i = Γ_inertial(q, 0, e_i) − Γ_inertial(q, 0, 0), Q(q) = Γ_inertial(q, 0, 0) + offsets,
C(q, q̇) q̇ = Γ_inertial(q, q̇, 0) − Γ_inertial(q, 0, 0), F_v e_i = Γ_FV(q, e_i, 0), F_c e_i = Γ_FS(q, e_i, 0).
The maps are evaluated over a Cartesian grid around a natural pose (the pose of best-conditioned Jacobian,
found numerically), in an operator frame whose z axis points against gravity. "Maximum" values are the
largest singular values (S2: "obtained through SVD decomposition"), the worst direction of the handle.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from tendyn.analysis.handle_point import HandlePoint
from tendyn.device.stiffness import reflected_stiffness, total_stiffness
from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.results import Result, format_table

__all__ = ["OperationalModel", "OperationalMaps", "MapFigure", "ParamsError", "operational_maps", "read_params",
           "true_params", "maps_summary", "natural_pose", "DEFAULT_HALF_WIDTH", "DEFAULT_POINTS"]

DEFAULT_HALF_WIDTH = 0.05
"""Half-width [m] of the grid cube around the natural handle position (a 100 mm cube, half the 200 mm
translation range S2 §IV gives for the full device)."""
DEFAULT_POINTS = 11
"""Grid points per axis (odd, so that the lines through the natural pose are on the grid)."""
DEFAULT_SPEED = 0.1
"""Handle speed [m/s] at which the velocity part of F_d is reported."""
NEIGHBOURHOODS = (0.01, 0.02, 0.03, 0.04, 0.05, 0.075, 0.1)
"""Half-widths [m] of the cubes of the neighbourhood profile (maxima vs distance from the natural pose)."""


# --------------------------------------------------------------------------------------------------------
# the identification contract
# --------------------------------------------------------------------------------------------------------

# ParamsError and read_params live in tendyn.io.params (PARAMS.json is a file format: identification reads it
# too); imported here, where they were first written, so that callers keep their import
from tendyn.io.params import ParamsError, read_params  # noqa: E402,F401


_TRUE_PARAMS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # per compiled device (a QR each)


def true_params(device: Device | CompiledDevice) -> list[dict]:
    """The twin's own base parameters in the identification contract (stderr 0): x_b = combination · x_std
    with the device file's standard link and drive parameters (what identification tries to recover; an
    estimator never reads it), through :func:`tendyn.device.closed_loop.base_parameters`."""
    from tendyn.device.closed_loop import base_parameters, drive_parameters
    from tendyn.device.rigid_body import standard_parameters, unit_of

    compiled = compile_device(device)
    if compiled in _TRUE_PARAMS:
        return [dict(p) for p in _TRUE_PARAMS[compiled]]
    bp = base_parameters(compiled)
    x = np.concatenate([standard_parameters(compiled.device)[1], drive_parameters(compiled.device)[1]])
    values = bp.values(x)
    out = []
    for i, name in enumerate(bp.names):
        lead = bp.standard_names[bp.base_columns[i]]
        terms = [f"{'-' if c < 0 else '+'} {abs(c):.6g}*{n}" for n, c in bp.terms(name).items() if n != lead]
        out.append({"name": name, "value": values[name], "stderr": 0.0, "rel_stderr_pct": 0.0, "unit": unit_of(name),
                    "expression": " ".join([lead] + terms)})
    _TRUE_PARAMS[compiled] = out
    return [dict(p) for p in out]


# --------------------------------------------------------------------------------------------------------
# the model at the handle
# --------------------------------------------------------------------------------------------------------

def _kind(std_name: str) -> str:
    stem = std_name.rstrip("0123456789")
    if stem in ("FV", "FVm"):
        return "viscous"
    if stem in ("FS", "FSm"):
        return "coulomb"
    if stem == "OFFSET":
        return "offset"
    return "inertial"


@dataclass(frozen=True)
class OperationalPoint:
    """The operational matrices at one pose (operator frame): M_op [kg], B_op [N·s/m], K_op [N/m], F_cop [N]
    (3 × 3 each), J [m/rad], and the active joints q [rad]."""

    q: np.ndarray
    J: np.ndarray
    M: np.ndarray
    B: np.ndarray
    K: np.ndarray
    Fc: np.ndarray

    @property
    def mass_singular_values(self) -> np.ndarray:
        """σ(M_op) [kg], descending: M_xx ≥ M_yy ≥ M_zz of S2 Fig. 8 (|eigenvalues|: M_op is symmetric)."""
        return np.sort(np.abs(np.linalg.eigvalsh(0.5 * (self.M + self.M.T))))[::-1]

    @property
    def worst_direction(self) -> np.ndarray:
        """Unit handle direction of the largest apparent mass (operator frame)."""
        w, v = np.linalg.eigh(0.5 * (self.M + self.M.T))
        u = v[:, int(np.argmax(np.abs(w)))]
        return u * (1 if u[np.argmax(np.abs(u))] > 0 else -1)

    @property
    def coulomb_singular_values(self) -> np.ndarray:
        """σ(F_cop) [N], descending (S2 Fig. 9: "maximum values of Coulomb friction … through SVD")."""
        return np.linalg.svd(self.Fc, compute_uv=False)

    def coulomb_vertex_max(self) -> float:
        """max over the sign patterns s ∈ {±1}³ of |J⁻ᵀ F_c s| [N]: the largest dry-friction force of a motion
        that moves every joint (the SVD value is that of a unit joint-space vector, up to √3 smaller)."""
        s = np.array([[a, b, c] for a in (1, -1) for b in (1, -1) for c in (1, -1)], float)
        return float(np.max(np.linalg.norm(s @ self.Fc.T, axis=1)))


class OperationalModel:
    """Joint-space dynamics from base parameters, and their image at the handle.

    Parameters
    ----------
    device : Device or CompiledDevice
        A serial device with capstan drives (``[[drives]]``: ratio N, K_T, K_E), e.g. ``cea_branch``.
    params : None, path, mapping or list
        Base parameters (:func:`read_params`); None: the twin's true ones (:func:`true_params`).
    stiffness_motor : sequence of float, optional
        Capstan stiffness K_T per drive [N·m/rad], motor side (identified, C31); default the device's.
    force : bool
        Use parameters whose document names another device.
    """

    def __init__(self, device, params=None, stiffness_motor=None, force: bool = False):
        from tendyn.device.closed_loop import base_parameters, drive_parameters
        from tendyn.device.rigid_body import standard_parameters, tree_joint_numbers

        self.compiled = compile_device(device)
        dev = self.compiled.device
        if dev.kind != "serial" or not dev.drives:
            raise ValueError(f"{dev.name}: the operational maps need capstan drives ([[drives]]: N, K_T, K_E)")
        self.device = dev
        numbers = tree_joint_numbers(dev)
        self.active_numbers = [numbers[k] for k in self.compiled.active_joints]
        names = standard_parameters(dev)[0] + drive_parameters(dev)[0]   # the columns of active_regressor
        self.params = true_params(self.compiled) if params is None else read_params(
            params, dev, force, standard_names=names, base_names=base_parameters(self.compiled).names)
        self.standard_names = tuple(names)
        self._drive_rows = [self.active_numbers.index(d.joint) for d in dev.drives]
        self._pm = self.compiled.pinocchio_model
        self._pd = self.compiled.pinocchio_data()
        idx = {n: k for k, n in enumerate(names)}
        self.x = np.zeros(len(names))
        self.columns = []
        for i, p in enumerate(self.params):
            lead = p["expression"].split()[0].lstrip("+")
            k = idx[lead]                           # a standard parameter: read_params checked it
            if k in self.columns:
                raise ParamsError(f"two parameters use the column {lead}", f"params[{i}].expression")
            self.columns.append(k)
            self.x[k] = p["value"]
        self.columns = np.array(self.columns, int)
        self.stderr = np.array([p["stderr"] for p in self.params], float)
        self.kinds = np.array([_kind(n) for n in names])
        drives = sorted(dev.drives, key=lambda d: d.joint)
        act = self.active_numbers
        if [d.joint for d in drives] != act:
            raise ValueError(f"{dev.name}: one drive per active joint expected (drives {[d.joint for d in drives]}, "
                             f"active joints {act})")
        self.drives = drives
        self.ratio = np.array([d.ratio for d in drives], float)
        kt = np.array([d.stiffness_motor for d in drives], float) if stiffness_motor is None else \
            np.asarray(stiffness_motor, float)
        if kt.shape != self.ratio.shape or not np.all(np.isfinite(kt)) or np.any(kt <= 0):
            raise ValueError(f"stiffness_motor: one positive K_T per drive expected ({len(drives)} values, "
                             f"got {list(np.atleast_1d(kt))})")
        self.stiffness_motor = kt
        ke = np.array([np.inf if d.servo_stiffness_motor is None else d.servo_stiffness_motor for d in drives])
        self.servo_stiffness_motor = ke
        self.total_stiffness_motor = total_stiffness(kt, ke)                        # S2 eq. 19 (motor side)
        self.joint_stiffness = reflected_stiffness(self.total_stiffness_motor, self.ratio)  # N² K_tot (ERRATA eq. 19)
        # the handle point and its kinematics (tendyn.analysis.handle_point, shared with the cable maps)
        self.handle = HandlePoint(self.compiled)
        self.L, self.c = self.handle.L, self.handle.c
        self.frame = self.handle.frame   # base ← operator

    # ---- kinematics (the handle point) -----------------------------------------------------------------
    def position(self, qa) -> np.ndarray:
        """Handle position [m], operator frame (:meth:`HandlePoint.position`)."""
        return self.handle.position(qa)

    def jacobian(self, qa) -> np.ndarray:
        """J = ∂X/∂q_a [m/rad] (3 × n_active), operator frame (:meth:`HandlePoint.jacobian`)."""
        return self.handle.jacobian(qa)

    def jdot_qd(self, qa, qd) -> np.ndarray:
        """J̇ q̇ [m/s²], operator frame (:meth:`HandlePoint.jdot_qd`)."""
        return self.handle.jdot_qd(qa, qd)

    def within_limits(self, qa, margin: float = 0.0) -> bool:
        """Every tree joint inside its limits [rad] (:meth:`HandlePoint.within_limits`)."""
        return self.handle.within_limits(qa, margin)

    def inverse_kinematics(self, x, q_start, step: float = 0.01, tol: float = 1e-10):
        """Active joints [rad] putting the handle at x [m] on q_start's branch
        (:meth:`HandlePoint.inverse_kinematics`)."""
        return self.handle.inverse_kinematics(x, q_start, step, tol)

    # ---- joint-space dynamics from the base parameters ---------------------------------------------------
    def regressor(self, q, qd, qdd) -> np.ndarray:
        """W(q, q̇, q̈) of each sample, (n_samples, n_active, n_standard): the closed-loop regressor in active
        coordinates (:func:`tendyn.device.closed_loop.active_regressor`, S2 eqs. 2 and 12), columns
        :attr:`standard_names` (links, then IA, FV, FS, OFFSET per drive)."""
        from tendyn.device.closed_loop import active_regressor

        q, qd, qdd = (np.atleast_2d(np.asarray(a, float)) for a in (q, qd, qdd))
        return np.array([active_regressor(self._pm, self.L, self.c, a, b, e, self._drive_rows, self._pd)
                         for a, b, e in zip(q, qd, qdd)])

    def _gamma(self, q, qd, qdd, kind: str | None = None, x=None) -> np.ndarray:
        """Σ_k x_k W_k over the columns of one kind: (n_samples, n_active) [N·m]."""
        xx = self.x if x is None else x
        if kind is not None:
            xx = np.where(self.kinds == kind, xx, 0.0)
        return self.regressor(q, qd, qdd) @ xx

    def mass_matrix(self, qa, x=None) -> np.ndarray:
        """A(q) [kg·m²], active coordinates, rotor inertias included: A e_i = Γ(q, 0, e_i) − Γ(q, 0, 0)."""
        na = len(self.ratio)
        q = np.tile(np.asarray(qa, float), (na + 1, 1))
        qdd = np.vstack([np.eye(na), np.zeros(na)])
        g = self._gamma(q, np.zeros_like(q), qdd, "inertial", x)
        return (g[:na] - g[na]).T

    def gravity(self, qa) -> np.ndarray:
        """Q(q) [N·m]: gravity torques of the base parameters (no offsets)."""
        z = np.zeros(len(self.ratio))
        return self._gamma(qa, z, z, "inertial")[0]

    def offsets(self) -> np.ndarray:
        """Constant offset torques [N·m] (S2 eq. 1)."""
        z = np.zeros(len(self.ratio))
        return self._gamma(z, z, z, "offset")[0]

    def coriolis(self, qa, qd) -> np.ndarray:
        """C(q, q̇) q̇ [N·m]: Γ_inertial(q, q̇, 0) − Q(q)."""
        z = np.zeros(len(self.ratio))
        g = self._gamma(np.vstack([qa, qa]), np.vstack([qd, z]), np.vstack([z, z]), "inertial")
        return g[0] - g[1]

    def viscous_matrix(self, qa, x=None) -> np.ndarray:
        """F_v [N·m·s/rad]: F_v e_i = Γ_FV(q, e_i, 0)."""
        na = len(self.ratio)
        return self._gamma(np.tile(qa, (na, 1)), np.eye(na), np.zeros((na, na)), "viscous", x).T

    def coulomb_matrix(self, qa, x=None) -> np.ndarray:
        """F_c [N·m]: F_c e_i = Γ_FS(q, e_i, 0) (diag(FS) for friction at the drives)."""
        na = len(self.ratio)
        return self._gamma(np.tile(qa, (na, 1)), np.eye(na), np.zeros((na, na)), "coulomb", x).T

    def friction(self, qd, factor: float = 1.0) -> np.ndarray:
        """factor · (F_v q̇ + F_c sign(q̇)) [N·m] (S2 eq. 15)."""
        z = np.zeros(len(self.ratio))
        qd = np.asarray(qd, float)
        return factor * (self._gamma(z, qd, z, "viscous")[0] + self._gamma(z, qd, z, "coulomb")[0])

    # ---- at the handle ----------------------------------------------------------------------------------
    def at(self, qa, x=None) -> OperationalPoint:
        """M_op, B_op, K_op, F_cop at active joints qa [rad] (S2 eqs. 18–19, ERRATA eq. 19)."""
        qa = np.asarray(qa, float)
        J = self.jacobian(qa)
        Ji = np.linalg.inv(J)
        A = self.mass_matrix(qa, x)
        return OperationalPoint(qa, J, Ji.T @ A @ Ji, Ji.T @ self.viscous_matrix(qa, x) @ Ji,
                                Ji.T @ np.diag(self.joint_stiffness) @ Ji, Ji.T @ self.coulomb_matrix(qa, x))

    def disturbance(self, qa, qd) -> np.ndarray:
        """F_d [N] = J⁻ᵀ (Q(q) + offsets + C(q, q̇) q̇ − A(q) J⁻¹ J̇ q̇) (S2 eq. 20, corrected: ERRATA)."""
        qa, qd = np.asarray(qa, float), np.asarray(qd, float)
        J = self.jacobian(qa)
        tau = self.gravity(qa) + self.offsets() + self.coriolis(qa, qd) \
            - self.mass_matrix(qa) @ np.linalg.solve(J, self.jdot_qd(qa, qd))
        return np.linalg.solve(J.T, tau)

    def grid_values(self, Q, handle_velocities):
        """Batched :meth:`at` and :meth:`disturbance` over poses Q (m, n_active) [rad] in one regressor call.

        Returns (points, fd0, fd): the :class:`OperationalPoint` of each pose, F_d at rest (m, 3) [N], and F_d at
        each handle velocity of ``handle_velocities`` (d, 3) [m/s] (m, d, 3) [N]."""
        Q = np.atleast_2d(np.asarray(Q, float))
        V = np.atleast_2d(np.asarray(handle_velocities, float))
        na, m, nd = len(self.ratio), Q.shape[0], V.shape[0]
        J = np.array([self.jacobian(q) for q in Q])
        qdv = np.array([[np.linalg.solve(Jk, v) for v in V] for Jk in J])                  # (m, d, na)
        jdq = np.array([[self.jdot_qd(q, qd) for qd in qds] for q, qds in zip(Q, qdv)])     # (m, d, 3)
        per = 1 + 2 * na + nd
        E, Z = np.eye(na), np.zeros((na, na))
        qs = np.repeat(Q, per, axis=0)
        qd = np.concatenate([np.vstack([np.zeros((1 + na, na)), E, qdv[k]]) for k in range(m)])
        qdd = np.concatenate([np.vstack([np.zeros((1, na)), E, Z, np.zeros((nd, na))]) for _ in range(m)])
        W = self.regressor(qs, qd, qdd).reshape(m, per, na, -1)
        xk = {kind: np.where(self.kinds == kind, self.x, 0.0) for kind in ("inertial", "viscous", "coulomb", "offset")}
        points, fd0, fd = [], np.empty((m, 3)), np.empty((m, nd, 3))
        for k in range(m):
            Wk = W[k]
            g0 = Wk[0] @ xk["inertial"] + Wk[0] @ xk["offset"]
            A = (Wk[1:1 + na] @ xk["inertial"] - Wk[0] @ xk["inertial"]).T
            Fv = (Wk[1 + na:1 + 2 * na] @ xk["viscous"]).T
            Fc = (Wk[1 + na:1 + 2 * na] @ xk["coulomb"]).T
            Ji = np.linalg.inv(J[k])
            points.append(OperationalPoint(Q[k], J[k], Ji.T @ A @ Ji, Ji.T @ Fv @ Ji,
                                           Ji.T @ np.diag(self.joint_stiffness) @ Ji, Ji.T @ Fc))
            fd0[k] = Ji.T @ g0
            cq = Wk[1 + 2 * na:] @ xk["inertial"] - Wk[0] @ xk["inertial"]                 # C(q, q̇) q̇ (d, na)
            tau = g0 + cq - (A @ (Ji @ jdq[k].T)).T
            fd[k] = tau @ Ji
        return points, fd0, fd

    def stderr_of(self, qa, quantity) -> float:
        """Standard deviation of ``quantity(OperationalPoint)`` at qa from the parameters' stderr (first order,
        parameters independent: the contract carries no covariance); the quantity's derivative along each
        parameter by a one-sided difference of one stderr."""
        qa = np.asarray(qa, float)
        ref = quantity(self.at(qa))
        var = 0.0
        for k, s in zip(self.columns, self.stderr):
            if s <= 0:
                continue
            x = self.x.copy()
            x[k] += s
            var += (quantity(self.at(qa, x)) - ref) ** 2
        return float(math.sqrt(var))

    def max_mass_stderr(self, qa) -> float:
        """Standard deviation [kg] of the largest apparent mass at qa (:meth:`stderr_of`)."""
        return self.stderr_of(qa, lambda p: float(p.mass_singular_values[0]))


def natural_pose(model: OperationalModel, n: int = 41) -> np.ndarray:
    """The natural pose [rad]: every active joint but the last two at mid-range, the last two (the arm plane,
    q2 and q5 on the CEA branch) chosen on an n × n grid inside the limits to maximise σ_min(J)/σ_max(J), then
    refined: the handle where the branch is most isotropic (on the CEA branch J = 0.3 m · orthogonal at
    q = (0, 0, π/2): the elbow square, the handle 0.3 m from axis 1)."""
    from scipy.optimize import minimize

    joints = model.device.kinematics.joints
    act = model.active_numbers
    lo = np.array([joints[j - 1].lower for j in act], float)
    hi = np.array([joints[j - 1].upper for j in act], float)
    q = 0.5 * (lo + hi)

    def inv_cond(qq):
        s = np.linalg.svd(model.jacobian(qq), compute_uv=False)
        return s[-1] / s[0]

    best, arg = -1.0, None
    for a in np.linspace(lo[-2], hi[-2], n)[1:-1]:
        for b in np.linspace(lo[-1], hi[-1], n)[1:-1]:
            qq = q.copy()
            qq[-2:] = (a, b)
            if not model.within_limits(qq, margin=0.05):
                continue
            v = inv_cond(qq)
            if v > best:
                best, arg = v, qq
    if arg is None:
        raise ValueError(f"{model.device.name}: no pose inside the joint limits")
    res = minimize(lambda z: -inv_cond(np.concatenate([q[:-2], z])), arg[-2:], method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-14})
    cand = np.concatenate([q[:-2], res.x])
    return cand if model.within_limits(cand) and inv_cond(cand) >= best else arg


# --------------------------------------------------------------------------------------------------------
# maps over the workspace grid
# --------------------------------------------------------------------------------------------------------

def _line_sel(offsets, axis: int, tol=1e-12):
    others = [k for k in range(3) if k != axis]
    return np.all(np.abs(offsets[:, others]) < tol, axis=1)


@dataclass(eq=False)
class MapFigure(Result):
    """S2 Fig. 8 (``kind="mass_stiffness"``: σ(M_op) and the diagonal of K_op) or Fig. 9 (``kind="friction"``:
    σ(F_cop) and the diagonal of B_op) along the three operator axes through the natural pose."""

    maps: Any
    kind: str = "mass_stiffness"
    _panels = 2
    _figsize = (5.5, 4.0)

    reading = ("Each curve is one quantity along a line through the natural pose (solid: x, dashed: y, dotted: z "
               "offset of the handle); the colour names the component, the zero offset is the natural pose.")

    def _draw(self, ax) -> None:
        m = self.maps
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        if self.kind == "mass_stiffness":
            quantities = ((m.mass_sv, ("M_xx", "M_yy", "M_zz"), 1e3, "apparent mass (singular values) [g]"),
                          (m.stiffness_diag, ("K_xx", "K_yy", "K_zz"), 1.0, "operational stiffness (diagonal) [N/m]"))
            title = ("Fig. 8 (S2): " if m.paper else "") + "apparent mass and operational stiffness"
        else:
            quantities = ((m.coulomb_sv, ("F_c,xx", "F_c,yy", "F_c,zz"), 1.0, "Coulomb friction (singular values) [N]"),
                          (m.viscous_diag, ("B_xx", "B_yy", "B_zz"), 1.0, "viscous friction (diagonal) [N·s/m]"))
            title = ("Fig. 9 (S2): " if m.paper else "") + "operational Coulomb and viscous friction"
        styles = ("-", "--", ":")
        for a, (values, labels, scale, ylabel) in zip(axes, quantities):
            for axis, ls in enumerate(styles):
                sel = _line_sel(m.offsets, axis) & m.reachable
                order = np.argsort(m.offsets[sel, axis])
                d = 1e3 * m.offsets[sel, axis][order]
                for comp in range(3):
                    a.plot(d, scale * values[sel][order, comp], ls=ls, color=f"C{comp}", lw=1.2,
                           label=f"{labels[comp]}" if axis == 0 else None)
            a.axvline(0.0, color="0.7", lw=0.6)
            a.set_xlabel("handle offset from the natural pose [mm] (— x, -- y, ·· z)")
            a.set_ylabel(ylabel)
            a.grid(alpha=0.3)
            a.legend(fontsize=7)
        axes[0].set_title(f"{m.device}: {title}", fontsize=9)

    def to_dict(self) -> dict:
        return {"kind": self.kind, **self.maps.to_dict()}

    def table(self) -> str:
        return self.maps.table()


@dataclass(eq=False)
class OperationalMaps(Result):
    """Operational maps over the grid (C41–C45).

    Attributes
    ----------
    device : name
    offsets : (n_pts, 3) handle offsets from the natural handle position [m], operator frame
    reachable : (n_pts,) inside every joint limit (IK on the natural pose's branch)
    q : (n_pts, 3) active joints [rad] (nan where unreachable)
    mass_sv, coulomb_sv : (n_pts, 3) singular values of M_op [kg], F_cop [N], descending
    stiffness_diag, viscous_diag : (n_pts, 3) diagonals of K_op [N/m], B_op [N·s/m]
    coulomb_vertex : (n_pts,) max_s |J⁻ᵀ F_c s| [N]
    fd_static, fd_dynamic : (n_pts,) |F_d| at rest (gravity + offsets) [N], and the largest |F_d − F_d(q̇=0)|
        over handle directions at ``speed`` [N]
    mass_pd : (n_pts,) M_op positive definite (false flags a poor identification)
    natural : dict of the natural-pose values; workspace : dict (C45); neighbourhood : list of dict
    """

    device: str
    half_width: float
    points: int
    speed: float
    offsets: np.ndarray
    reachable: np.ndarray
    q: np.ndarray
    mass_sv: np.ndarray
    stiffness_diag: np.ndarray
    coulomb_sv: np.ndarray
    viscous_diag: np.ndarray
    coulomb_vertex: np.ndarray
    fd_static: np.ndarray
    fd_dynamic: np.ndarray
    mass_pd: np.ndarray
    natural: dict
    workspace: dict
    neighbourhood: list
    stiffness_motor: list
    params_source: str = "identified"
    paper: bool = False          # the device is S2's twin (cea_branch): the table shows S2's printed values
    _panels = 4
    _figsize = (5.0, 4.0)

    @property
    def figures(self) -> dict:
        """{"fig8": MapFigure (mass, stiffness), "fig9": MapFigure (friction)}."""
        return {"fig8": MapFigure(self, "mass_stiffness"), "fig9": MapFigure(self, "friction")}

    reading = ('Each curve is one quantity along a line through the natural pose (solid: x, dashed: y, dotted: z '
               'offset of the handle); the colour names the component.')

    def _draw(self, ax) -> None:
        axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
        if len(axes) < 4:
            MapFigure(self, "mass_stiffness")._draw(axes)
            return
        MapFigure(self, "mass_stiffness")._draw(axes[:2])
        MapFigure(self, "friction")._draw(axes[2:4])

    def _r(self, a):
        return a[self.reachable]

    @property
    def warnings(self) -> list[str]:
        """What the maps cannot be trusted for: a natural-pose apparent mass or dry friction whose σ (from the
        parameters' σ) is more than half its value, grid points where the identified mass matrix is not positive
        definite (the inertia is not physical), a negative largest apparent mass or dry friction."""
        out = []
        nat = self.natural
        for key, sig, what, unit, scale in (("apparent_mass_kg", "apparent_mass_stderr_kg", "apparent mass", "g", 1e3),
                                            ("dry_friction_N", "dry_friction_stderr_N", "dry friction", "N", 1.0)):
            v, s = float(nat[key][0]), float(nat[sig])
            if not np.isfinite(s) or s > 0.5 * abs(v):
                out.append(f"{what} at the natural pose {scale * v:.4g} ± {scale * s:.2g} {unit}: its σ is "
                           f"{100 * s / max(abs(v), 1e-300):.0f} % of the value, the identified parameters do not "
                           "determine it (identify on a more exciting log; see the identification's warnings)")
        bad = int(np.sum(~self.mass_pd & self.reachable))
        if bad:
            out.append(f"the identified mass matrix is not positive definite at {bad} of {int(self.reachable.sum())} "
                       "reachable grid points: no real device has this inertia (identify --consistent)")
        return out

    def to_dict(self) -> dict:
        k = self._r(self.stiffness_diag)
        return {
            "device": self.device,
            "warnings": self.warnings,
            "params": self.params_source,
            "max_apparent_mass_kg": float(np.max(self._r(self.mass_sv)[:, 0])),
            "stiffness_range_N_per_m": [float(np.min(k)), float(np.max(k))],
            "max_dry_friction_N": float(np.max(self._r(self.coulomb_sv)[:, 0])),
            "dry_friction_range_N": [float(np.min(self._r(self.coulomb_sv)[:, 0])),
                                     float(np.max(self._r(self.coulomb_sv)[:, 0]))],
            "max_dry_friction_all_joints_moving_N": float(np.max(self._r(self.coulomb_vertex))),
            "max_viscous_N_s_per_m": float(np.max(self._r(self.viscous_diag))),
            "max_fd_static_N": float(np.max(self._r(self.fd_static))),
            "max_fd_dynamic_N": float(np.max(self._r(self.fd_dynamic))),
            "fd_speed_m_per_s": self.speed,
            "mass_not_positive_definite_points": int(np.sum(~self.mass_pd & self.reachable)),
            "stiffness_motor_N_m_per_rad": list(self.stiffness_motor),
            "grid": {"half_width_m": self.half_width, "points_per_axis": self.points,
                     "points": int(self.reachable.size), "reachable": int(self.reachable.sum()),
                     "frame": "operator: z against gravity, x the horizontal part of base x0, y = z × x"},
            "natural_pose": self.natural,
            "workspace": self.workspace,
            "neighbourhood": self.neighbourhood,
        }

    def table(self) -> str:
        d = self.to_dict()
        nat = self.natural
        rows = [
            ("max apparent mass (natural pose) [g]",
             f"{1e3 * nat['apparent_mass_kg'][0]:.4g} ± {1e3 * nat['apparent_mass_stderr_kg']:.2g}", "≈ 650 (±30 %)"),
            ("max apparent mass (grid) [g]", 1e3 * d["max_apparent_mass_kg"], "up to 800 (±30 %)"),
            ("stiffness (natural pose) [N/m]", "–".join(f"{v:.0f}" for v in nat["stiffness_diag_N_per_m"]),
             "2000–5000"),
            ("stiffness range (grid) [N/m]", "–".join(f"{v:.0f}" for v in d["stiffness_range_N_per_m"]), "2000–5000"),
            ("max dry friction (natural pose) [N]",
             f"{nat['dry_friction_N'][0]:.4g} ± {nat['dry_friction_stderr_N']:.2g}", "0.3–0.4 (±30 %)"),
            ("max dry friction (grid) [N]", d["max_dry_friction_N"], "0.3–0.4 (±30 %)"),
            ("dry friction, every joint moving (grid) [N]", d["max_dry_friction_all_joints_moving_N"], "–"),
            ("max viscous friction (grid) [N·s/m]", d["max_viscous_N_s_per_m"], "–"),
            (f"|F_d| at rest / at {self.speed:g} m/s (grid) [N]",
             f"{d['max_fd_static_N']:.3g} / {d['max_fd_dynamic_N']:.3g}", "–"),
            ("reachable cube edge around the natural pose [mm]", 1e3 * self.workspace["reachable_cube_edge_m"],
             "> 200 (full device)"),
            ("reachable extents x, y, z [mm]", " × ".join(f"{1e3 * v:.0f}" for v in self.workspace["extents_m"]), "–"),
        ]
        headers = ("quantity", self.device, "S2 (paper)") if self.paper else ("quantity", self.device)
        rows = rows if self.paper else [r[:2] for r in rows]
        text = format_table(headers, rows,
                            title=f"{self.device}: operational maps ({self.params_source} parameters), grid "
                                  f"±{1e3 * self.half_width:g} mm, {self.points}³ points, "
                                  f"{int(self.reachable.sum())} reachable")
        prof = format_table(("half-width [mm]", "max mass [g]", "K min [N/m]", "K max [N/m]", "max F_c [N]"),
                            [(1e3 * r["half_width_m"], 1e3 * r["max_apparent_mass_kg"], r["stiffness_range_N_per_m"][0],
                              r["stiffness_range_N_per_m"][1], r["max_dry_friction_N"]) for r in self.neighbourhood],
                            title="maxima over cubes around the natural pose")
        q = ", ".join(f"{v:.4g}" for v in nat["q_active_rad"])
        return text + f"\nnatural pose q = ({q}) rad, handle at " \
                      f"{', '.join(f'{1e3 * v:.1f}' for v in nat['handle_position_m'])} mm\n\n" + prof


def _neighbourhood(maps_arrays, offsets, reachable, widths):
    mass_sv, stiff, coul = maps_arrays
    out = []
    for h in widths:
        sel = reachable & np.all(np.abs(offsets) <= h + 1e-12, axis=1)
        if not sel.any():
            continue
        out.append({"half_width_m": float(h), "points": int(sel.sum()),
                    "max_apparent_mass_kg": float(mass_sv[sel, 0].max()),
                    "stiffness_range_N_per_m": [float(stiff[sel].min()), float(stiff[sel].max())],
                    "max_dry_friction_N": float(coul[sel, 0].max())})
    return out


CUBE_SEARCH_MAX_HALF_M = 0.4
"""Largest half-edge [m] the reachable-cube search tries (C45)."""


def _ray_reach(model: OperationalModel, q0, x0, u, s_max: float, tol: float, step: float = 0.02) -> float:
    """The largest s ≤ ``s_max`` [m] (to ``tol``) such that the handle goes from x0 to x0 + s·u along the ray inside
    the joint limits: walked out from the natural pose in legs of ``step`` [m] (each leg's inverse kinematics starts
    from the last one's solution, the continuation :meth:`OperationalModel.inverse_kinematics` does inside a leg),
    then bisected between the last reachable point and the first unreachable one."""
    q, s = np.array(q0, float), 0.0
    ds = step / float(np.linalg.norm(u))
    while s < s_max:
        s_next = min(s + ds, s_max)
        qn = model.inverse_kinematics(x0 + s_next * u, q, step=step)
        if qn is not None and model.within_limits(qn):
            q, s = qn, s_next
            continue
        lo, hi = s, s_next
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            qm = model.inverse_kinematics(x0 + mid * u, q, step=step)
            if qm is not None and model.within_limits(qm):
                lo, q = mid, qm
            else:
                hi = mid
        return lo
    return s_max


def _workspace(model: OperationalModel, q0, x0, n_cube: int = 7, n_joint: int = 17, tol: float = 1e-3) -> dict:
    """C45: the edge of the largest cube centred on the natural handle position whose surface (n_cube² points
    per face) is reachable inside the joint limits, to ``tol`` [m] on the half-edge, and the extents of the handle
    positions over a joint-space grid of the limits (every tree joint checked).

    The half-edge is the smallest reach along the rays from the centre through the surface points (the reachable
    set has no holes around the natural pose): each ray is walked out once and bisected at its end, capped at the
    smallest reach found so far. A bisection of the whole surface (every ray walked again from the natural pose
    for each trial size) gave the same edges within the tolerance and took 3–4× longer (issue 39: 2.4 → 0.7 s on
    the CEA branch; tests/python/test_s2_maps.py checks the edge against the surface solved directly)."""
    g = np.linspace(-1.0, 1.0, n_cube)
    unit = np.array([[a, b, c] for a in g for b in g for c in g if max(abs(a), abs(b), abs(c)) == 1.0])
    half = CUBE_SEARCH_MAX_HALF_M
    for u in unit:
        half = min(half, _ray_reach(model, q0, x0, u, half, tol))
    joints = model.device.kinematics.joints
    act = model.active_numbers
    grids = [np.linspace(joints[j - 1].lower, joints[j - 1].upper, n_joint) for j in act]
    pts = []
    for qa in np.stack(np.meshgrid(*grids, indexing="ij"), -1).reshape(-1, len(act)):
        if model.within_limits(qa):
            pts.append(model.position(qa))
    pts = np.array(pts)
    return {"reachable_cube_edge_m": float(2 * half), "cube_grid_points_per_axis": n_cube,
            "extents_m": [float(v) for v in pts.max(0) - pts.min(0)],
            "bounding_box_min_m": [float(v) for v in pts.min(0)], "bounding_box_max_m": [float(v) for v in pts.max(0)],
            "joint_grid_points_per_axis": n_joint,
            "note": "branch only (S2 C45: > 200 mm in every direction for the full 6-DOF device)"}


def operational_maps(device, params=None, *, stiffness_motor=None, q_natural=None,
                     half_width: float = DEFAULT_HALF_WIDTH, points: int = DEFAULT_POINTS,
                     speed: float = DEFAULT_SPEED, neighbourhoods: Sequence[float] = NEIGHBOURHOODS,
                     workspace: bool = True, quick: bool = False, progress=None) -> OperationalMaps:
    """Operational maps of a capstan-driven branch from base parameters (C41–C45).

    Parameters
    ----------
    device : Device, CompiledDevice
    params : None (the twin's true base parameters), a PARAMS.json path, the identify document or its list
    stiffness_motor : K_T per drive [N·m/rad] motor side (default the device's capstan stiffness)
    q_natural : active joints of the natural pose [rad] (default :func:`natural_pose`)
    half_width : [m] of the grid cube around the natural handle position; points : per axis (odd)
    speed : handle speed [m/s] of the velocity part of F_d
    neighbourhoods : half-widths [m] of the cubes of the neighbourhood profile
    workspace : compute the workspace size (C45; a few seconds)
    quick : 5 points per axis and a coarse workspace search (tests, ``--quick`` pipelines)
    progress : callable(str) for progress messages (stderr in the commands)

    Returns
    -------
    OperationalMaps (``to_dict()`` is the ``maps`` summary: :func:`maps_summary`)
    """
    if quick:
        points = min(points, 5)
    if points < 3 or points % 2 == 0:
        raise ValueError(f"points must be odd and >= 3 (got {points})")
    if not half_width > 0:
        raise ValueError(f"half_width must be > 0 [m] (got {half_width})")
    model = device if isinstance(device, OperationalModel) else OperationalModel(device, params, stiffness_motor)
    q0 = natural_pose(model) if q_natural is None else np.asarray(q_natural, float)
    if not model.within_limits(q0):
        raise ValueError(f"q_natural = {list(q0)} rad is outside the joint limits")
    x0 = model.position(q0)
    g = np.linspace(-half_width, half_width, points)
    offsets = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    # visit the grid from the centre outward, warm-starting from the nearest solved neighbour's pose
    order = np.argsort(np.linalg.norm(offsets, axis=1), kind="stable")
    n = offsets.shape[0]
    Q = np.full((n, 3), np.nan)
    reach = np.zeros(n, bool)
    step = g[1] - g[0]
    solved = {}
    for k in order:
        key = tuple(np.round(offsets[k] / step).astype(int))
        start = q0
        for nb in ((key[0] - int(np.sign(key[0])), key[1], key[2]), (key[0], key[1] - int(np.sign(key[1])), key[2]),
                   (key[0], key[1], key[2] - int(np.sign(key[2])))):
            if nb in solved:
                start = solved[nb]
                break
        q = model.inverse_kinematics(x0 + offsets[k], start)
        if q is not None and model.within_limits(q):
            Q[k], reach[k] = q, True
            solved[key] = q
    if progress:
        progress(f"maps: {int(reach.sum())}/{n} grid points reachable")
    mass_sv, stiff, coul, visc = (np.full((n, 3), np.nan) for _ in range(4))
    vertex, fd_s, fd_d = (np.full(n, np.nan) for _ in range(3))
    pd = np.zeros(n, bool)
    dirs = np.vstack([np.eye(3), -np.eye(3)])
    idx = np.flatnonzero(reach)
    for k, p, f0, fdyn in zip(idx, *model.grid_values(Q[idx], speed * dirs)):
        mass_sv[k] = p.mass_singular_values
        pd[k] = bool(np.all(np.linalg.eigvalsh(0.5 * (p.M + p.M.T)) > 0))
        stiff[k], visc[k] = np.diag(p.K), np.diag(p.B)
        coul[k] = p.coulomb_singular_values
        vertex[k] = p.coulomb_vertex_max()
        fd_s[k] = np.linalg.norm(f0)
        fd_d[k] = max(np.linalg.norm(f - f0) for f in fdyn)
    p0 = model.at(q0)
    nat = {"q_active_rad": [float(v) for v in q0], "handle_position_m": [float(v) for v in x0],
           "jacobian_singular_values_m_per_rad": [float(v) for v in np.linalg.svd(p0.J, compute_uv=False)],
           "apparent_mass_kg": [float(v) for v in p0.mass_singular_values],
           "apparent_mass_stderr_kg": model.max_mass_stderr(q0),
           "worst_direction": [float(v) for v in p0.worst_direction],
           "stiffness_diag_N_per_m": [float(v) for v in np.diag(p0.K)],
           "stiffness_eigenvalues_N_per_m": [float(v) for v in np.linalg.eigvalsh(p0.K)],
           "dry_friction_N": [float(v) for v in p0.coulomb_singular_values],
           "dry_friction_stderr_N": model.stderr_of(q0, lambda p: float(p.coulomb_singular_values[0])),
           "dry_friction_all_joints_moving_N": p0.coulomb_vertex_max(),
           "viscous_diag_N_s_per_m": [float(v) for v in np.diag(p0.B)],
           "fd_static_N": float(np.linalg.norm(model.disturbance(q0, np.zeros(3))))}
    ws = _workspace(model, q0, x0, **(dict(n_cube=3, n_joint=9, tol=5e-3) if quick else {})) if workspace else {"reachable_cube_edge_m": float("nan"), "extents_m": [float("nan")] * 3}
    if progress and workspace:
        progress(f"maps: reachable cube edge {1e3 * ws['reachable_cube_edge_m']:.0f} mm")
    prof = _neighbourhood((mass_sv, stiff, coul), offsets, reach, [h for h in neighbourhoods if h <= half_width + 1e-12])
    source = "true" if params is None and not isinstance(device, OperationalModel) else "identified"
    from tendyn.devices import is_twin_of

    return OperationalMaps(model.device.name, float(half_width), int(points), float(speed), offsets, reach, Q,
                           mass_sv, stiff, coul, visc, vertex, fd_s, fd_d, pd, nat, ws, prof,
                           [float(v) for v in model.stiffness_motor], source, is_twin_of(model.device, "cea_branch"))


def maps_summary(maps: OperationalMaps) -> dict:
    """The ``maps`` part of ``tendyn pipeline s2 --json`` (``max_apparent_mass_kg``,
    ``stiffness_range_N_per_m``, ``max_dry_friction_N``, natural-pose values, workspace)."""
    return maps.to_dict()
