"""The constant-velocity test of S0 §III-A as one definition: what ``tendyn plan`` writes, what the twin runs
(``tendyn simulate … constant-velocity``) and what ``tendyn identify-friction`` accepts all come from here, so a
test planned with the defaults is always one the identification takes.

A test moves one transmission back and forth at ``speeds`` (motor side, one forward and one backward pass
each) over a stroke that fits inside the joint limits, at one or more **poses** (the other joints held there,
S2; or their motors, S1): the poses are chosen so that the lossless load torque the cable carries differs,
which the load-dependent friction term of :mod:`tendyn.ident.friction` needs. Nothing here knows a particular
device: strokes come from the joint limits, poses from the limits and the device's own gravity model, and a
test that cannot satisfy the identification's needs is refused before it is written, naming the transmission,
what was found and the option that fixes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.errors import UsageError

DEFAULT_SPEEDS = (2.0, 4.0, 6.0, 8.0, 10.0)
"""Motor speeds [rad/s] of a planned test, one forward and one backward pass each."""
MIN_SPEEDS = 5
"""Fewest distinct speeds per direction the identification accepts (C7: a line through ≥ 5 points per side)."""
DEFAULT_TRAVEL = 20.0
"""Longest motor travel per pass [rad]; shortened to fit the joint limits."""
DEFAULT_ACCEL = 200.0
"""Ramp acceleration [rad/s²] at the motor."""
DEFAULT_LOADS = 2
"""Poses (gravity loads) per test: two, so that the load-dependent term is identifiable."""
LIMIT_MARGIN = 0.05
"""Share of each joint's range kept clear of its limits by a planned stroke or pose [-]."""
DWELL_S = 0.1
"""Rest between passes [s]."""
SETTLE_S = 0.5
"""Rest after moving to a new pose [s] (the position loop settles before the next pass)."""

PLATEAU = dict(window_s=0.04, tol=0.02, min_speed=0.2, min_duration_s=0.15, trim_s=0.05)
"""Plateau detection of the identification (:func:`tendyn.ident.plateaus.find_plateaus`)."""
LOOP_BANDWIDTH_HZ = 12.0
"""Position-loop bandwidth [Hz] of the twin's constant-velocity test: at 6 Hz the integral action leaves a speed
drift of ~10 % over a short stroke on L-EXOS and light distal links never hold a plateau; at 12 Hz the speed is
flat within 1 % after ~0.1 s (a lab's own loop is its own; the plan's strokes leave it LOOP_SETTLE_S)."""
LOOP_SETTLE_S = 0.6
"""Time [s] a position loop takes to hold the speed within the plateau tolerance after a ramp (a light distal
link on a 6 Hz loop, measured on generated devices: 0.4–0.7 s at 10 rad/s)."""


def cruise_needed_s() -> float:
    """Time at constant speed [s] a pass needs for the identification to pair it with the pass back: each pass
    holds its speed only after the loop settles (and the detection's trim and window), at its far end for one
    direction and at its near end for the other, so their steady parts overlap by the shortest plateau only when
    the cruise lasts twice the settling plus that plateau."""
    p = PLATEAU
    return 2.0 * (LOOP_SETTLE_S + p["trim_s"] + p["window_s"]) + p["min_duration_s"]


def fastest_speed(travel: float, accel: float) -> float:
    """The highest speed [rad/s] whose pass of ``travel`` [rad] holds it for :func:`cruise_needed_s` (the root of
    v²/a + v T = travel)."""
    T = cruise_needed_s()
    return 0.5 * accel * (-T + math.sqrt(T * T + 4.0 * travel / accel))


def travel_needed(speed: float, accel: float) -> float:
    """Motor travel [rad] of a pass that reaches ``speed`` [rad/s] at ``accel`` [rad/s²] and holds it for
    :func:`cruise_needed_s`."""
    return speed * speed / accel + speed * cruise_needed_s()


@dataclass(frozen=True)
class ConstantVelocityTest:
    """One planned constant-velocity test of one transmission.

    transmission : 1-based; strategy : "S1" (other motors held) or "S2" (other joints held)
    speeds : motor speeds [rad/s]; travel : motor travel per pass [rad]; accel : [rad/s²]
    poses : (k, n) start joint positions [rad], one per load (the stroke goes from there, the driven joint
        moving by travel / G[j, j]); load_motor : (k,) lossless gravity torque at the motor in the middle of each
        stroke [N·m] (the device's model: information, the identification measures its own)
    notes : what the planner decided and why
    """

    transmission: int
    strategy: str
    speeds: tuple
    travel: float
    accel: float
    poses: np.ndarray
    load_motor: np.ndarray
    notes: tuple = field(default=())

    def options(self) -> dict:
        """The log metadata of the test (``meta.options``), JSON-able."""
        return {"transmission": self.transmission, "strategy": self.strategy,
                "speeds_motor": [float(v) for v in self.speeds], "travel_motor": float(self.travel),
                "accel_motor": float(self.accel), "q0": self.poses[0].tolist(), "poses": self.poses.tolist(),
                "load_motor": [float(x) for x in self.load_motor], "notes": list(self.notes)}


def _limits(device):
    js = device.kinematics.joints
    lo = np.array([j.lower for j in js], float)
    hi = np.array([j.upper for j in js], float)
    return lo, hi


def motor_from_joint(device) -> np.ndarray:
    """G (n, n) [rad/rad], q_motor = G q_active, of a device with cable transmissions (R_m⁻¹ K) or capstan drives
    (diag N): the matrix every constant-velocity reference is built with."""
    from tendyn.device import compile_device

    return _Geometry(compile_device(device)).G


class _Geometry:
    """What a plan needs of any serial device with one motor per active joint (cable transmissions or capstan
    drives on a closed-loop tree): G = ∂q_motor/∂q_active (n, n), the active limits, the tree limits and the
    map q_tree = L q_active + c (passive joints of a parallelogram have limits too: the elbow's range is a
    limit on q5 − q2), gravity in active coordinates (S2 eq. 12: Lᵀ g_tree) and each motor's continuous
    torque [N·m]."""

    def __init__(self, compiled):
        dev = compiled.device
        self.compiled = compiled
        if dev.transmissions:
            mats = compiled.transmission.matrices()      # refuses an N+1 routing (exit 2)
            self.G = np.asarray(mats["motor_from_joint_position"], float)
            self.motors = [t.motor for t in dev.transmissions]
        else:
            self.G = np.asarray(dev.motor_joint_matrix(), float)
            self.motors = [d.motor for d in dev.drives]
        self.M = np.linalg.inv(self.G).T                 # motor torques from active-joint torques
        from tendyn.device.rigid_body import tree_joint_numbers

        joints = dev.kinematics.joints
        numbers = tree_joint_numbers(dev)
        self.L, self.c = (np.asarray(a, float) for a in compiled.active_map)
        self.tree_lo = np.array([joints[k - 1].lower for k in numbers], float)
        self.tree_hi = np.array([joints[k - 1].upper for k in numbers], float)
        act = [numbers[k] for k in compiled.active_joints]
        self.active_numbers = act
        self.lo = np.array([joints[k - 1].lower for k in act], float)
        self.hi = np.array([joints[k - 1].upper for k in act], float)
        self.tree_margin = LIMIT_MARGIN * (self.tree_hi - self.tree_lo)
        self.names = [joints[k - 1].name for k in numbers]
        self.tree_numbers = numbers

    def inside(self, q, margin: bool = True) -> np.ndarray:
        """(k,) True where the active poses q (k, n) keep every tree joint inside its limits (less the margin)."""
        qt = np.atleast_2d(q) @ self.L.T + self.c
        m = self.tree_margin if margin else 0.0
        return np.all((qt >= self.tree_lo + m - 1e-12) & (qt <= self.tree_hi - m + 1e-12), axis=1)

    def interval(self, q, j: int, margin: bool = True) -> tuple[float, float]:
        """The range [a, b] [rad] of active joint j with the other active joints at q, every tree joint inside
        its limits (less the margin); a > b when there is none."""
        m = self.tree_margin if margin else 0.0
        q = np.asarray(q, float).copy()
        q[j] = 0.0
        base = self.L @ q + self.c
        a, b = -np.inf, np.inf
        for k in range(self.L.shape[0]):
            coef = self.L[k, j]
            if coef == 0.0:
                if not self.tree_lo[k] + m[k] - 1e-12 <= base[k] <= self.tree_hi[k] - m[k] + 1e-12:
                    return 1.0, -1.0
                continue
            x1 = (self.tree_lo[k] + m[k] - base[k]) / coef
            x2 = (self.tree_hi[k] - m[k] - base[k]) / coef
            a, b = max(a, min(x1, x2)), min(b, max(x1, x2))
        return a, b

    def centre(self) -> np.ndarray:
        """An active pose deep inside every tree limit: mid-range when that is inside, else the centre of the
        largest ball in the polytope {lo ≤ L q + c ≤ hi} (Chebyshev centre, one linear programme)."""
        mid = 0.5 * (self.lo + self.hi)
        if self.inside(mid):
            return mid
        from scipy.optimize import linprog

        n = self.L.shape[1]
        A = np.vstack([self.L, -self.L])
        bnd = np.concatenate([self.tree_hi - self.tree_margin - self.c, -(self.tree_lo + self.tree_margin - self.c)])
        norms = np.linalg.norm(A, axis=1)
        keep = norms > 0
        res = linprog(np.r_[np.zeros(n), -1.0], A_ub=np.c_[A[keep], norms[keep]], b_ub=bnd[keep],
                      bounds=[(None, None)] * n + [(0, None)], method="highs")
        if not res.success or res.x[-1] <= 0.0:
            raise UsageError(f"{self.compiled.device.name}: no pose keeps every joint inside its limits (less "
                             f"{LIMIT_MARGIN:.0%} of each range): check the limits of the passive joints against "
                             "their constraints", "device")
        return res.x[:n]

    def gravity_motor(self, poses) -> np.ndarray:
        """Lossless motor torques [N·m] holding each active pose against gravity, G⁻ᵀ Lᵀ g(L q + c) (S0 eq. 5,
        corrected: ERRATA; S2 eq. 12), (k, n)."""
        import pinocchio as pin

        pm = self.compiled.pinocchio_model
        pd = pm.createData()
        return np.array([self.M @ (self.L.T @ pin.computeGeneralizedGravity(pm, pd, self.L @ np.asarray(q, float)
                                                                             + self.c)) for q in poses])


def plan_test(device, transmission: int, strategy: str = "S2", speeds=None, travel: float | None = None,
              accel: float | None = None, q0=None, loads: int = DEFAULT_LOADS,
              strict: bool = True) -> ConstantVelocityTest:
    """Plan the constant-velocity test of ``transmission`` on any serial device with cable transmissions or
    capstan drives (a closed-loop tree too: the passive joints keep inside their limits over every stroke).

    Stroke: from ``q0`` if given (the driven joint moves up from it), else centred in the driven joint's range;
    the motor travel is ``travel`` or the longest that stays :data:`LIMIT_MARGIN` inside the limits, at most
    :data:`DEFAULT_TRAVEL`; default speeds are scaled down where the stroke is too short for them. ``strict=False``
    lets a twin run what it is told (``tendyn simulate`` with explicit --speeds or a short travel): fewer than
    :data:`MIN_SPEEDS` speeds or passes shorter than :func:`cruise_needed_s` become notes, not refusals (the
    identification may then refuse the log). Poses (``loads`` of them): the first holds the other joints at ``q0`` or mid-range;
    the others are chosen among the corners and middles of the other joints' ranges for the largest change of
    the gravity load at the motor, with every motor's holding torque within its continuous torque.

    Raises
    ------
    UsageError
        The test cannot satisfy the identification: fewer than :data:`MIN_SPEEDS` speeds, or a pass too short
        for a plateau at the highest speed (naming the transmission, the numbers and the option to change).
    """
    from tendyn.device import compile_device

    compiled = compile_device(device)
    dev = compiled.device
    if getattr(dev, "kind", None) != "serial" or not (dev.n_transmissions or getattr(dev, "drives", ())):
        raise UsageError(f"{dev.name} has no cable transmissions or capstan drives to test", "device")
    geo = _Geometry(compiled)
    G = geo.G
    n = G.shape[0]
    if not 1 <= transmission <= n:
        raise UsageError(f"must be 1…{n} (got {transmission})", "transmission")
    if strategy not in ("S1", "S2"):
        raise UsageError(f"must be S1 or S2 (got {strategy!r})", "strategy")
    default_speeds = speeds is None
    speeds = tuple(float(v) for v in (DEFAULT_SPEEDS if speeds is None else speeds))
    accel = float(DEFAULT_ACCEL if accel is None else accel)
    j = transmission - 1
    distinct = sorted(set(round(v, 9) for v in speeds))
    if strict and len(distinct) < MIN_SPEEDS:
        raise UsageError(f"transmission {transmission}: {len(distinct)} distinct speeds, the identification needs "
                         f"at least {MIN_SPEEDS} per direction", "speeds")
    if G[j, j] == 0.0:  # the stroke is planned on the driven joint: travel / G[j, j]
        name = dev.transmissions[j].name
        raise UsageError(f"transmission {name} does not wrap joint {transmission} (zero driven radius): "
                         f"isolated moves of that joint (S2) cannot be driven by its motor alone; this protocol "
                         f"needs a nonzero diagonal of K", "transmission")
    notes = []
    if q0 is not None:
        q0 = np.asarray(q0, float)
        if q0.shape != (n,):
            raise UsageError(f"{q0.size} values, {dev.name} has {n} active joints", "q0")
        outside = [k for k in range(n) if not geo.lo[k] <= q0[k] <= geo.hi[k]]
        if outside:
            k = outside[0]
            raise UsageError(f"joint {geo.active_numbers[k]} = {q0[k]:g} rad is outside its limits "
                             f"[{geo.lo[k]:g}, {geo.hi[k]:g}] rad", "q0")
        if not geo.inside(q0, margin=False)[0]:
            raise UsageError(f"{', '.join(f'{v:g}' for v in q0)} rad puts a passive joint outside its limits "
                             f"({_worst(geo, q0)})", "q0")
        a, b = geo.interval(q0, j)
        room_joint = b - q0[j]
    else:
        centre = geo.centre()
        a, b = geo.interval(centre, j)
        room_joint = b - a
    room_motor = abs(G[j, j]) * max(room_joint, 0.0)
    if travel is None:
        travel = min(DEFAULT_TRAVEL, room_motor)
        if travel < DEFAULT_TRAVEL:
            notes.append(f"motor travel {travel:.3g} rad: the longest stroke inside joint {transmission}'s limits")
    if default_speeds and travel_needed(max(speeds), accel) > travel:
        scale = fastest_speed(travel, accel) / max(speeds)
        speeds = tuple(math.floor(v * scale * 1000.0) / 1000.0 for v in speeds)   # rounded down: still fits
        notes.append(f"speeds scaled by {scale:.3g} to {', '.join(f'{v:g}' for v in speeds)} rad/s: the stroke "
                     "holds the default ones too briefly")
    needed = travel_needed(max(speeds), accel)
    if travel > room_motor + 1e-12:
        raise UsageError(f"transmission {transmission}: a motor travel of {travel:g} rad moves joint "
                         f"{transmission} by {travel / abs(G[j, j]):.3g} rad, past its limits (room "
                         f"{room_motor:.3g} rad at the motor)", "travel")
    if travel < needed and not strict:
        notes.append(f"at {max(speeds):g} rad/s a pass of {travel:.3g} rad holds the speed less than "
                     f"{cruise_needed_s():.2f} s: the identification may not pair it")
    elif travel < needed:
        v = max(speeds)
        raise UsageError(f"transmission {transmission}: at {v:g} rad/s a pass of {travel:.3g} rad (motor) leaves "
                         f"{max(0.0, (travel - v * v / accel) / v):.3g} s at constant speed; the identification "
                         f"needs {cruise_needed_s():.2f} s ({needed:.3g} rad): lower the highest of --speeds, "
                         f"raise --accel, or widen joint {transmission}'s limits", "speeds")
    stroke_joint = travel / G[j, j]          # signed: the joint moves this way for a positive motor pass
    if q0 is None:
        first = centre.copy()
        first[j] = 0.5 * (a + b) - 0.5 * stroke_joint
    else:
        first = q0.copy()
    poses = [first]
    if loads > 1:
        poses += _load_poses(geo, j, first, stroke_joint, loads - 1, notes)
    poses = np.array(poses)
    mids = poses.copy()
    mids[:, j] += 0.5 * stroke_joint
    load = geo.gravity_motor(mids)[:, j] if np.linalg.norm(dev.kinematics.gravity) > 0 else np.zeros(len(poses))
    if len(poses) < loads:
        notes.append(f"{len(poses)} pose(s): the gravity load on transmission {transmission} does not change with "
                     "the other joints (the load term then needs an added load, e.g. a mass on the link)")
    return ConstantVelocityTest(transmission, strategy, speeds, float(travel), accel, poses, np.asarray(load),
                                tuple(notes))


def _worst(geo, q) -> str:
    """'joint 3 (elbow) = 2.7 rad, limits [0.45, 2.5]' for the tree joint furthest outside its limits at q."""
    qt = geo.L @ np.asarray(q, float) + geo.c
    out = np.maximum(geo.tree_lo - qt, qt - geo.tree_hi)
    k = int(np.argmax(out))
    return (f"joint {geo.tree_numbers[k]} ({geo.names[k]}) = {qt[k]:.3g} rad, limits "
            f"[{geo.tree_lo[k]:.3g}, {geo.tree_hi[k]:.3g}] rad")


def _load_poses(geo, j, first, stroke_joint, count, notes) -> list:
    """``count`` poses whose gravity load at motor j differs most from the first pose's (within every motor's
    continuous torque, every tree joint inside its limits over the whole stroke); none when gravity is zero or
    the load does not depend on the other joints."""
    dev = geo.compiled.device
    n = first.size
    lo, hi = geo.lo + LIMIT_MARGIN * (geo.hi - geo.lo), geo.hi - LIMIT_MARGIN * (geo.hi - geo.lo)
    if np.linalg.norm(dev.kinematics.gravity) == 0:
        notes.append("no gravity: one pose (the load term needs an added load)")
        return []
    others = [k for k in range(n) if k != j]
    levels = [np.array([lo[k], 0.5 * (lo[k] + hi[k]), hi[k]]) for k in others]
    # joint j's own stroke centre also sets the load: try its range too (the stroke must fit)
    j_lo, j_hi = (lo[j], hi[j] - stroke_joint) if stroke_joint > 0 else (lo[j] - stroke_joint, hi[j])
    j_levels = np.array([j_lo, first[j], j_hi]) if j_hi >= j_lo else np.array([first[j]])
    rng = np.random.default_rng(0)
    total = len(j_levels) * 3 ** len(others)
    if total <= 729:
        grids = np.meshgrid(j_levels, *levels, indexing="ij")
        combos = np.stack([g.ravel() for g in grids], axis=1)
    else:   # 7 or more joints: a fixed sample of the corners and middles
        combos = np.column_stack([rng.choice(j_levels, 729)] + [rng.choice(lv, 729) for lv in levels])
    cand = np.tile(first, (combos.shape[0], 1))
    cand[:, j] = combos[:, 0]
    cand[:, others] = combos[:, 1:]
    ends = cand.copy()
    ends[:, j] += stroke_joint
    mids = cand.copy()
    mids[:, j] += 0.5 * stroke_joint
    tau = geo.gravity_motor(mids)
    mid_first = first.copy()
    mid_first[j] += 0.5 * stroke_joint
    base = geo.gravity_motor([mid_first])[0, j]
    cont = np.array([m.continuous_torque for m in geo.motors])
    # the moves between poses are straight lines in active coordinates: every tree limit is linear in q, so a
    # pose whose stroke start and end are inside keeps the whole stroke (and the move from `first`) inside
    ok = np.all(np.abs(tau) <= cont, axis=1) & geo.inside(cand) & geo.inside(ends)
    change = np.where(ok, np.abs(np.abs(tau[:, j]) - abs(base)), -1.0)
    best = int(np.argmax(change))
    scale = max(abs(base), float(np.abs(tau[:, j]).max()), 1e-12)
    if change[best] <= 0.05 * scale:
        return []
    far = cand[best]
    return [first + (far - first) * (k + 1) / count for k in range(count)]


# ---- references ------------------------------------------------------------------------------------

def constant_velocity_duration(speeds, travel: float = 20.0, accel: float = 200.0, dwell: float = 0.1) -> float:
    """Length [s] of :func:`constant_velocity_profile` (to size a run before it starts)."""
    total = 0.0
    for v in speeds:
        t_acc = v / accel
        total += 2.0 * (2.0 * t_acc + max(travel - v * t_acc, 0.0) / v + dwell)
    return total


def constant_velocity_profile(speeds, travel: float, accel: float, dt: float, dwell: float = 0.1):
    """Back-and-forth moves at each constant speed (trapezoidal velocity): returns (q, qd).

    speeds [unit/s] > 0, travel [unit] per stroke, accel [unit/s²] for the ramps; its length is
    :func:`constant_velocity_duration`."""
    qd = []
    for v in speeds:
        t_acc = v / accel
        cruise = max(travel - v * t_acc, 0.0) / v
        ramp = np.arange(0.0, t_acc, dt) * accel
        stroke = np.concatenate([ramp, np.full(int(round(cruise / dt)), v), ramp[::-1],
                                 np.zeros(int(round(dwell / dt)))])
        qd += [stroke, -stroke]
    qd = np.concatenate(qd)
    return np.cumsum(qd) * dt, qd


def check_index(value, n: int, what: str) -> int:
    """A 1-based index inside 1…n (so that 0 or -1 never wraps to the last entry)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= n:
        raise ValueError(f"{what} must be an integer in 1…{n} (got {value!r})")
    return int(value)


def constant_velocity_references(motor_from_joint, transmission: int, speeds, strategy: str, travel: float,
                                 accel: float, q0, dt: float):
    """References of the S0 constant-velocity test (used by :func:`constant_velocity` and by
    ``tendyn plan``): returns (ref_q, ref_qd, space), (n_samples, n) on the grid ``dt`` [s].

    S1 — motor space ("motor"): motor ``transmission`` follows the back-and-forth profile, every other motor
    is held at its start q_m0 = G q0. S2 — joint space ("joint"): joint ``transmission`` moves at the motor
    speeds scaled by 1/G[j, j] (the motor speed with the other joints still), every other joint is held at q0.
    motor_from_joint G (n, n) [-] maps joint to motor positions (R_m⁻¹ K); speeds [rad/s], travel [rad]
    and accel [rad/s²] are on the motor."""
    Gm = np.asarray(motor_from_joint, float)
    nm, na = Gm.shape          # N+1 tendons: nm = na + 1 motors, S2 only (transmission = the joint moved)
    j = check_index(transmission, nm if strategy == "S1" else na, "transmission") - 1
    q0 = np.asarray(q0, float)
    q_prof, qd_prof = constant_velocity_profile(np.asarray(speeds, float), travel, accel, dt)
    n = q_prof.size
    if strategy == "S1":
        ref_q = np.tile(Gm @ q0, (n, 1))
        ref_qd = np.zeros((n, nm))
        ref_q[:, j] += q_prof
        ref_qd[:, j] = qd_prof
        return ref_q, ref_qd, "motor"
    if strategy == "S2":
        # joint j speed for motor speed 1 with the other joints still (N+1: the fastest motor of joint j)
        scale = 1.0 / Gm[j, j] if nm == na else 1.0 / np.abs(Gm[:, j]).max()
        ref_q = np.tile(q0, (n, 1))
        ref_qd = np.zeros((n, na))
        ref_q[:, j] += q_prof * scale
        ref_qd[:, j] = qd_prof * scale
        return ref_q, ref_qd, "joint"
    raise ValueError(f"strategy must be 'S1' or 'S2' (got {strategy!r})")


def _transition_s(G, a, b, speeds) -> float:
    """Length [s] of the raised-cosine move between poses a and b [rad]: its peak motor speed (π/2)·D/T is
    the highest test speed (D the largest motor displacement), at least 1 s."""
    dist = float(np.abs(np.asarray(G, float) @ (np.asarray(b, float) - np.asarray(a, float))).max())
    return max(1.0, 0.5 * math.pi * dist / max(speeds))


def references(motor_from_joint, test: ConstantVelocityTest, dt: float):
    """References of ``test`` on the grid ``dt`` [s]: (ref_q, ref_qd, space), (n_samples, n).

    At each pose: the back-and-forth passes at every speed (:func:`constant_velocity_references`: S1 — motor
    space, every other motor holds; S2 — joint space, every other joint holds the pose). Between poses: a
    raised-cosine move of every joint (S2) or motor (S1), :func:`_transition_s` long, then :data:`SETTLE_S` at
    rest."""
    G = np.asarray(motor_from_joint, float)
    parts_q, parts_v = [], []
    space = "motor" if test.strategy == "S1" else "joint"
    for k, pose in enumerate(test.poses):
        if k > 0:
            a = parts_q[-1][-1]
            b = G @ pose if space == "motor" else np.asarray(pose, float)
            T = _transition_s(G, test.poses[k - 1], pose, test.speeds)
            t = np.arange(int(round(T / dt))) * dt
            s = 0.5 * (1 - np.cos(math.pi * t / T))
            ds = 0.5 * math.pi / T * np.sin(math.pi * t / T)
            rest = int(round(SETTLE_S / dt))
            parts_q += [a + np.outer(s, b - a), np.tile(b, (rest, 1))]
            parts_v += [np.outer(ds, b - a), np.zeros((rest, G.shape[0]))]
        q, v, space = constant_velocity_references(G, test.transmission, test.speeds, test.strategy, test.travel,
                                                   test.accel, pose, dt)
        parts_q.append(q)
        parts_v.append(v)
    return np.concatenate(parts_q), np.concatenate(parts_v), space


def duration_s(motor_from_joint, test: ConstantVelocityTest) -> float:
    """Length [s] of the references of ``test`` (to size a run before it starts)."""
    one = constant_velocity_duration(test.speeds, test.travel, test.accel, DWELL_S)
    moves = sum(_transition_s(motor_from_joint, a, b, test.speeds) + SETTLE_S
                for a, b in zip(test.poses[:-1], test.poses[1:]))
    return len(test.poses) * one + moves
