"""Closed kinematic loops of an mdh tree: active coordinates, constrained dynamics and base parameters.

A closed-loop mechanism is modelled as its equivalent tree (the mdh rows without the σ = 2 frames, see
:func:`tendyn.device.rigid_body.joint_frames`) plus linear constraints on the passive joints
(``[[kinematics.constraints]]``): q_tree = L q_active + c. Since the map is linear, v_tree = L q̇_a and
a_tree = L q̈_a, and the principle of virtual work gives the active-joint torques (S2 eq. 12)

    Γ_m = [I Lᵀ] Γ_ar = Lᵀ Γ_tree,          A_a(q_a) = Lᵀ A_tree(q_tree) L,

with Γ_tree from the recursive Newton–Euler algorithm of the tree (rows of L for active joints are the
identity rows). Friction, offsets and rotor inertias of the drives act on the active joints directly.

Base parameters (S2 section V.D, Gautier 1991): the regressor of the constrained model in the active
coordinates, W_a = Lᵀ Y_tree (Y_tree = ``pin.computeJointTorqueRegressor``, 10 standard parameters per link
about the link frame origin) plus the drive columns, is sampled at random (q_a, q̇_a, q̈_a); its rank is the
number of base parameters; walking the columns in a preference order, a column is *base* when it is
independent of the base columns before it, and every other column is a fixed combination of base ones:
W = W_b [1 β]  ⇒  x_b = x_base + β x_other (the regrouping). Nothing here is specific to the CEA branch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Device
from .compiled import CompiledDevice, compile_device
from .rigid_body import (
    active_coordinate_map,
    cut_frames,
    rot_x,
    rot_z,
    trans,
    standard_parameters,
    tree_joint_numbers,
)

__all__ = [
    "BaseParameters",
    "active_coordinate_map",
    "active_dynamics",
    "active_mass_matrix",
    "active_regressor",
    "base_parameters",
    "drive_parameters",
    "end_effector_point",
    "loop_closure_error",
]


def _tree_state(L, c, qa, qda=None, qdda=None):
    q = L @ np.asarray(qa, float) + c
    v = None if qda is None else L @ np.asarray(qda, float)
    a = None if qdda is None else L @ np.asarray(qdda, float)
    return q, v, a


def active_dynamics(model, L, c, qa, qda, qdda, data=None) -> np.ndarray:
    """Rigid-body torques at the active joints, Γ_m = Lᵀ rnea(q_tree, v_tree, a_tree) [N·m] (S2 eq. 12).

    Parameters
    ----------
    model : pinocchio.Model
        The tree (:func:`tendyn.device.rigid_body.pinocchio_model`).
    L, c : from :func:`active_coordinate_map`.
    qa, qda, qdda : (n_active,) active positions [rad], velocities [rad/s], accelerations [rad/s²].
    data : pinocchio.Data, optional (allocated if absent).
    """
    import pinocchio as pin

    data = model.createData() if data is None else data
    q, v, a = _tree_state(L, c, qa, qda, qdda)
    return L.T @ pin.rnea(model, data, q, v, a)


def active_mass_matrix(model, L, c, qa, data=None) -> np.ndarray:
    """Mass matrix in active coordinates, A_a = Lᵀ A_tree(q_tree) L [kg·m²], symmetric (n_active, n_active)."""
    import pinocchio as pin

    data = model.createData() if data is None else data
    q, _, _ = _tree_state(L, c, qa)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    return L.T @ M @ L


def _closing_pairs(device) -> list[tuple[int, int]]:
    """(cut-joint frame k, closing frame k+1) pairs: a σ = 2 row j closes the loop at frame j − 1 when
    row j − 1 is a constrained passive joint (Khalil–Kleinfinger numbering: the closing frame follows the
    frame of the cut joint)."""
    kin = device.kinematics
    constrained = {con.joint for con in getattr(kin, "constraints", ())}
    pairs = []
    for cf in cut_frames(device):
        k = cf.number - 1
        if k >= 1 and kin.joints[k - 1].sigma != 2 and k in constrained:
            pairs.append((k, cf.number))
    return pairs


def loop_closure_error(device: Device | CompiledDevice, qa, pairs=None, model=None) -> np.ndarray:
    """Mismatch between the two frames of each cut joint at active positions qa.

    Parameters
    ----------
    device : Device
    qa : (n_active,) active joint positions [rad].
    pairs : list of (k, j), optional
        File frame numbers (frame k of the cut joint on one side, fixed frame j on the other); by default
        every σ = 2 row j that follows a constrained passive joint k = j − 1 (for the CEA branch: (7, 8)).
    model : pinocchio.Model, optional (built from the device if absent).

    Returns
    -------
    ndarray, shape (6 * n_pairs,)
        Per pair: the position of frame j minus that of frame k in the base frame [m], then the rotation
        vector of R_kᵀ R_j [rad] (zero when ᵏA_j = I). ~0 for any qa when the constraints close the loops.
    """
    import pinocchio as pin

    compiled = compile_device(device)   # the one model of the device (built once)
    device = compiled.device
    model = compiled.pinocchio_model if model is None else model
    data = model.createData()
    L, c = compiled.active_map
    q, _, _ = _tree_state(L, c, qa)
    pin.forwardKinematics(model, data, q)
    numbers = tree_joint_numbers(device)
    tree_idx = {num: k + 1 for k, num in enumerate(numbers)}
    fixed = {cf.number: cf for cf in cut_frames(device)}
    pairs = _closing_pairs(device) if pairs is None else pairs

    def world(num: int) -> np.ndarray:
        if num in tree_idx:
            return data.oMi[tree_idx[num]].homogeneous
        cf = fixed[num]
        base = np.eye(4) if cf.parent == 0 else data.oMi[cf.parent].homogeneous
        return base @ cf.placement

    out = []
    for k, j in pairs:
        Tk, Tj = world(k), world(j)
        out.append(Tj[:3, 3] - Tk[:3, 3])
        out.append(pin.log3(Tk[:3, :3].T @ Tj[:3, :3]))
    return np.concatenate(out) if out else np.zeros(0)


def end_effector_point(device: Device | CompiledDevice) -> tuple[int, np.ndarray]:
    """(0-based joint, point [m] in that joint frame) of the end effector: for standard DH the origin of the
    last DH frame (the handle of L-EXOS, ``a4`` along x4), seen from the last joint frame; for a tree with
    closed loops (mdh with cut joints) the origin of the frame of the last leaf of the tree that is not a cut
    joint (the CEA branch: frame 4, the handle support at the end of the forearm, not the cut joint 7 that
    closes the parallelogram); otherwise the origin of the last joint frame."""
    compiled = compile_device(device)
    kin = compiled.device.kinematics
    frames = compiled.joint_frames
    n = len(frames)
    if kin.convention == "dh":
        js = kin.joints[-1]
        link = rot_z(js.theta_offset) @ trans(z=js.d) @ trans(x=js.a) @ rot_x(js.alpha)
        return n - 1, np.array(link[:3, 3], float)
    if kin.convention == "mdh":
        cut = {k for k, _ in _closing_pairs(compiled.device)}
        if cut:
            numbers = tree_joint_numbers(compiled.device)
            parents = {f.parent for f in frames}
            leaves = [i for i in range(n) if (i + 1) not in parents and numbers[i] not in cut]
            if leaves:
                return leaves[-1], np.zeros(3)
    return n - 1, np.zeros(3)


# --------------------------------------------------------------------------------------------------------
# regressor and base parameters
# --------------------------------------------------------------------------------------------------------

DRIVE_PARAMETER_NAMES = ("IA", "FV", "FS", "OFFSET")
"""Per drive, joint side: rotor inertia N² I_r [kg·m²], viscous N² ν_m [N·m·s/rad], Coulomb N C_m [N·m],
offset [N·m] (S2 eq. 1)."""


def drive_parameters(device) -> tuple[list[str], np.ndarray]:
    """Names (``"FV2"``) and joint-side values of the drive parameters, drives sorted by joint."""
    names, values = [], []
    for d in device.drives:
        names += [f"{p}{d.joint}" for p in DRIVE_PARAMETER_NAMES]
        values += [d.rotor_inertia_joint, d.viscous_joint, d.coulomb_joint, d.offset_joint]
    return names, np.array(values, dtype=float)


def active_regressor(model, L, c, qa, qda, qdda, drive_rows=(), data=None) -> np.ndarray:
    """One sample of the active-joint regressor, (n_active, 10 n_tree + 4 n_drives).

    Columns: the 10 standard parameters of each tree link (Pinocchio order M, MX, MY, MZ, XX, XY, YY, XZ,
    YZ, ZZ, about the link origin), then per drive (``drive_rows``: row index in the active vector of each
    drive's joint) IA, FV, FS, OFFSET: Γ_m = W x.
    """
    import pinocchio as pin

    data = model.createData() if data is None else data
    q, v, a = _tree_state(L, c, qa, qda, qdda)
    Y = L.T @ pin.computeJointTorqueRegressor(model, data, q, v, a)
    if not len(drive_rows):
        return Y
    na = L.shape[1]
    D = np.zeros((na, 4 * len(drive_rows)))
    qda, qdda = np.asarray(qda, float), np.asarray(qdda, float)
    for i, r in enumerate(drive_rows):
        D[r, 4 * i:4 * i + 4] = (qdda[r], qda[r], np.sign(qda[r]), 1.0)
    return np.hstack([Y, D])


@dataclass(frozen=True)
class BaseParameters:
    """Base (minimum) parameters of a device's dynamic model in active coordinates.

    Attributes
    ----------
    names : tuple of str
        Base parameter names: the name of the standard parameter whose column is kept, with "R" appended
        when other parameters are regrouped into it (S2 notation, e.g. "ZZ1R", "MY2").
    standard_names : tuple of str
        All standard parameters (columns): "XX3" = XX of the link of file joint 3, ..., then "IA2", "FV2",
        "FS2", "OFFSET2" per drive.
    combination : ndarray, shape (rank, n_standard)
        x_base = combination @ x_standard.
    base_columns : tuple of int
        Index in ``standard_names`` of the kept column of each base parameter.
    rank : int
        Numerical rank of the sampled regressor = number of base parameters.
    singular_values : ndarray
        Singular values of the column-normalised sampled regressor (the gap shows the rank is clear-cut).
    """

    names: tuple[str, ...]
    standard_names: tuple[str, ...]
    combination: np.ndarray
    base_columns: tuple[int, ...]
    rank: int
    singular_values: np.ndarray

    def terms(self, name: str, tol: float = 1e-9) -> dict[str, float]:
        """The regrouping of one base parameter: {standard name: coefficient} for nonzero coefficients."""
        row = self.combination[self.names.index(name)]
        return {self.standard_names[k]: float(row[k]) for k in np.flatnonzero(np.abs(row) > tol)}

    def values(self, x_standard) -> dict[str, float]:
        """Base parameter values {name: value} for a vector of standard parameters."""
        xb = self.combination @ np.asarray(x_standard, float)
        return dict(zip(self.names, map(float, xb)))


def _preference_order(standard_names, link_order):
    """Column preference: per link (``link_order``), XX XY XZ YZ ZZ MX MY first, then the usual regrouped ones
    (MZ, M, YY), then rotor inertias, then friction/offset (Khalil–Gautier naming: YY, MZ, M are eliminated)."""
    primary = ("XX", "XY", "XZ", "YZ", "ZZ", "MX", "MY")
    secondary = ("MZ", "M", "YY")
    idx = {n: k for k, n in enumerate(standard_names)}
    order = []
    for group in (primary, secondary):
        for num in link_order:
            order += [idx[f"{p}{num}"] for p in group if f"{p}{num}" in idx]
    for p in DRIVE_PARAMETER_NAMES:
        order += [k for k, n in enumerate(standard_names) if n.startswith(p) and n[len(p):].isdigit()
                  and k not in order]
    order += [k for k in range(len(standard_names)) if k not in order]
    return order


def base_parameters(device: Device | CompiledDevice, n_samples: int = 100, seed: int = 0, include_drives: bool = True,
                    link_order=None, tol: float = 1e-8) -> BaseParameters:
    """Base parameters of the device's dynamic model in active coordinates, found numerically.

    Parameters
    ----------
    device : Device
    n_samples : int
        Random (q_a, q̇_a, q̈_a) samples (q_a uniform in [−π, π], q̇_a and q̈_a standard normal).
    seed : int
        Seed of the samples.
    include_drives : bool
        Append the drive columns IA, FV, FS, OFFSET per drive (S2 Table 4 lists friction and offsets next to
        the inertial parameters; rotor inertias regroup into the ZZ of their joint's link).
    link_order : sequence of int, optional
        File joint numbers in order of preference for keeping a link's parameters (default: tree order, so
        the parameters of a link regroup into those of an earlier link when they can, e.g. ⁶J₆ into ²J₂).
    tol : float
        Relative tolerance on the QR diagonal of the column-normalised regressor.

    Returns
    -------
    BaseParameters
    """
    compiled = compile_device(device)   # the one model of the device (built once)
    device = compiled.device
    model = compiled.pinocchio_model
    data = compiled.pinocchio_data()
    active, (L, c) = compiled.active_joints, compiled.active_map
    numbers = tree_joint_numbers(device)
    std_names, _ = standard_parameters(device)
    drive_rows = []
    if include_drives:
        active_nums = [numbers[k] for k in active]
        drive_rows = [active_nums.index(d.joint) for d in device.drives]
        std_names = std_names + drive_parameters(device)[0]
    rng = np.random.default_rng(seed)
    na = len(active)
    W = np.vstack([active_regressor(model, L, c, rng.uniform(-np.pi, np.pi, na), rng.normal(size=na),
                                    rng.normal(size=na), drive_rows, data) for _ in range(n_samples)])
    norms = np.linalg.norm(W, axis=0)
    nonzero = norms > tol * norms.max()
    Wn = np.where(nonzero, W / np.where(nonzero, norms, 1.0), 0.0)
    sv = np.linalg.svd(Wn, compute_uv=False)
    import scipy.linalg     # here only: compiling a device or listing the commands does not load scipy

    _, Rp, _ = scipy.linalg.qr(Wn, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(Rp)) > tol * abs(Rp[0, 0])))
    order = _preference_order(std_names, numbers if link_order is None else list(link_order))
    _, R = np.linalg.qr(Wn[:, order])
    base = [order[k] for k in range(len(order)) if nonzero[order[k]] and abs(R[k, k]) > tol]
    if len(base) != rank:
        raise RuntimeError(f"base-parameter selection found {len(base)} independent columns but the pivoted "
                           f"QR rank is {rank}: increase n_samples or adjust tol")
    base.sort(key=order.index)
    other = [k for k in range(len(std_names)) if k not in base]
    beta, *_ = np.linalg.lstsq(W[:, base], W[:, other], rcond=None)
    beta[np.abs(beta) < 1e-10] = 0.0
    resid = np.linalg.norm(W[:, base] @ beta - W[:, other]) / max(np.linalg.norm(W), 1.0)
    if resid > 1e-9:
        raise RuntimeError(f"regrouping residual {resid:.3g}: the base columns do not span the regressor")
    comb = np.zeros((len(base), len(std_names)))
    for i, k in enumerate(base):
        comb[i, k] = 1.0
        comb[i, other] = beta[i]
    names = tuple(std_names[k] + ("R" if np.count_nonzero(comb[i]) > 1 else "") for i, k in enumerate(base))
    return BaseParameters(names=names, standard_names=tuple(std_names), combination=comb,
                          base_columns=tuple(base), rank=rank, singular_values=sv)
