"""The parts of a device description as frozen dataclasses built by :func:`tendyn.device.load_device`: joints
and kinematics, constraints, transmissions (branch friction, bearings, motor, sensors), capstan drives,
actuators and ``[[terms]]``. All values are SI and radians; joints and transmissions are numbered from 1."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

def _frozen_array(x, shape) -> np.ndarray:
    a = np.array(x, dtype=float).reshape(shape)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class JointSpec:
    """One joint (and the link it moves).

    For ``convention = "dh"``: a [m], alpha [rad], d [m], theta_offset [rad] (theta = q + theta_offset),
    lower/upper [rad], mass [kg], com [m] (3,), inertia [kg m^2] (6,) = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
    about the COM in the link frame. For ``"mdh"`` additionally j, antecedent, mu, sigma, gamma [rad],
    b [m], r [m] (a is None). For ``"urdf"`` only name, lower, upper are filled (None for continuous
    joints); the rest comes from the URDF itself.
    """

    name: str
    lower: float | None = None
    upper: float | None = None
    a: float | None = None
    alpha: float | None = None
    d: float | None = None
    theta_offset: float | None = None
    mass: float | None = None
    com: np.ndarray | None = None
    inertia: np.ndarray | None = None
    # modified DH (Khalil-Kleinfinger) only
    j: int | None = None
    antecedent: int | None = None
    mu: int | None = None
    sigma: int | None = None
    gamma: float | None = None
    b: float | None = None
    r: float | None = None

    @property
    def actuated(self) -> bool:
        """True unless an mdh entry says mu = 0."""
        return self.mu is None or self.mu == 1

    def inertia_matrix(self) -> np.ndarray | None:
        """The 3x3 inertia matrix [kg m^2] about the COM in the link frame (None if not given)."""
        if self.inertia is None:
            return None
        return inertia_matrix(self.inertia)


def inertia_matrix(v) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] -> symmetric 3x3 matrix (entries as in URDF)."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(x) for x in v)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Kinematic description.

    convention : "dh", "mdh" or "urdf"
    gravity : (3,) array [m/s^2], base frame
    joints : tuple of :class:`JointSpec`, in order (joint k is ``joints[k-1]``)
    urdf : resolved path of the URDF file, or None
    constraints : tuple of :class:`Constraint` (closed loops, "mdh" only), sorted by joint
    """

    convention: str
    gravity: np.ndarray
    joints: tuple[JointSpec, ...]
    urdf: Path | None = None
    constraints: tuple["Constraint", ...] = ()

    @property
    def n_joints(self) -> int:
        return len(self.joints)


@dataclass(frozen=True)
class Constraint:
    """A closed-loop constraint q_joint = sum_k terms[k] * q_k + offset (joints 1-based, k active).

    joint : the passive joint it determines; terms : tuple of (active joint, coefficient [-]) pairs sorted
    by joint; offset [rad] (or [m] for a prismatic joint).
    """

    joint: int
    terms: tuple[tuple[int, float], ...]
    offset: float = 0.0


@dataclass(frozen=True)
class BranchFriction:
    """Friction of one branch of a cable (S0 eqs. 11-12).

    tau0 [N] Coulomb force, nu [N s/m] viscous coefficient, beta [-] tension-proportional loss in [0, 1).
    """

    tau0: float
    nu: float
    beta: float = 0.0


@dataclass(frozen=True)
class Bearing:
    """Bearings of one branch (S0 eqs. 7-8).

    count [-], radius [m], wrap [rad], static_coefficient [m] (S0 eq. 7 alpha: torque per newton of radial
    load at break-away), dynamic_coefficient [m] (S0 eq. 7 beta: the same while turning), h0 [N m],
    h1 [N m (rad/s)^(-2/3)], n0 [rad/s].
    """

    count: int
    radius: float
    wrap: float
    static_coefficient: float
    dynamic_coefficient: float
    h0: float
    h1: float
    n0: float


@dataclass(frozen=True)
class Motor:
    """Motor data (motor side): torque_constant [N m/A], rotor_inertia [kg m^2], continuous_torque and
    peak_torque [N m]."""

    torque_constant: float
    rotor_inertia: float
    continuous_torque: float
    peak_torque: float

    @property
    def continuous_current(self) -> float:
        """Continuous current [A] = continuous_torque / torque_constant."""
        return self.continuous_torque / self.torque_constant


@dataclass(frozen=True)
class Sensors:
    """Sensors: encoder_counts [counts per motor revolution after decoding], current_noise [A rms]."""

    encoder_counts: int
    current_noise: float


@dataclass(frozen=True)
class TransmissionSpec:
    """One cable from a motor to its driven joint.

    joint is the driven joint number (1-based); crosses are the (1-based) joints crossed on idle pulleys
    with signed radii crossed_radii [m]; motor_radius, driven_radius [m]; reducer_ratio [-];
    reducer_efficiency eta_d [-]; pretension [N]; friction and bearings have one entry per branch
    (``joint`` branches: branch 0 on the base, branch b on link b); a bearings entry is None when the
    branch has none.
    """

    name: str
    joint: int
    motor_radius: float
    crosses: tuple[int, ...]
    crossed_radii: tuple[float, ...]
    driven_radius: float
    reducer_ratio: float
    reducer_efficiency: float
    pretension: float
    friction: tuple[BranchFriction, ...]
    bearings: tuple[Bearing | None, ...]
    motor: Motor
    sensors: Sensors
    antagonistic: bool = False

    @property
    def last_joint(self) -> int:
        """Last joint (1-based) the cable wraps: ``joint``, or a later crossed joint for a differential."""
        return max((self.joint, *self.crosses))

    @property
    def generalized_radius(self) -> float:
        """r_i^i = driven_radius * reducer_ratio [m] (S0 footnote 1, ERRATA)."""
        return self.driven_radius * self.reducer_ratio

    @property
    def n_branches(self) -> int:
        return self.last_joint

    @property
    def self_locking(self) -> bool:
        """True if eta_d <= 0.5: the reducer cannot be back-driven (ERRATA, eq. 10)."""
        return self.reducer_efficiency <= 0.5

    @property
    def inverse_efficiency(self) -> float:
        """eta_i = (2 eta_d - 1) / eta_d (S0 eq. 10); <= 0 means self-locking."""
        eta = self.reducer_efficiency
        return (2.0 * eta - 1.0) / eta


@dataclass(frozen=True)
class Drive:
    """Elastic capstan drive of one actuated joint (S2 eqs. 13-15; stiffnesses motor side, ERRATA eq. 19).

    joint [-] 1-based driven joint; ratio N [-] (motor speed = N * joint speed); stiffness_motor K_T
    [N m/rad]; damping_motor [N m s/rad]; coulomb_motor [N m]; viscous_motor [N m s/rad]; offset_joint
    [N m] (at the joint); servo_stiffness_motor K_E [N m/rad] or None; motor, sensors as for transmissions.
    """

    name: str
    joint: int
    ratio: float
    stiffness_motor: float
    damping_motor: float
    coulomb_motor: float
    viscous_motor: float
    offset_joint: float
    motor: Motor
    sensors: Sensors
    servo_stiffness_motor: float | None = None

    @property
    def coulomb_joint(self) -> float:
        """Coulomb friction seen at the joint [N m] = N * coulomb_motor (a motor torque C is N C at the joint)."""
        return self.ratio * self.coulomb_motor

    @property
    def viscous_joint(self) -> float:
        """Viscous friction seen at the joint [N m s/rad] = N^2 * viscous_motor (motor speed N qd)."""
        return self.ratio ** 2 * self.viscous_motor

    @property
    def stiffness_joint(self) -> float:
        """Capstan stiffness seen at the joint [N m/rad] = N^2 * stiffness_motor (ERRATA eq. 19,
        :func:`tendyn.device.stiffness.reflected_stiffness`)."""
        from .stiffness import reflected_stiffness

        return reflected_stiffness(self.stiffness_motor, self.ratio)

    @property
    def total_stiffness_motor(self) -> float:
        """K_tot = 1 / (1/K_T + 1/K_E) [N m/rad] at the motor (S2 eq. 19, :func:`tendyn.device.stiffness.total_stiffness`);
        K_T if K_E is not given."""
        from .stiffness import total_stiffness

        return total_stiffness(self.stiffness_motor, self.servo_stiffness_motor)

    @property
    def rotor_inertia_joint(self) -> float:
        """Rotor inertia reflected to the joint [kg m^2] = N^2 * rotor_inertia."""
        return self.ratio ** 2 * self.motor.rotor_inertia


@dataclass(frozen=True)
class Actuator:
    """A geared motor driving one actuated joint, possibly coupled to others (``[[actuators]]``).

    joint [-] 1-based driven joint; ratio N [-] (signed); coupling: tuple of (joint, coefficient [-]) pairs,
    sorted, so that q_motor = N (q_joint + sum(coef q_k)); encoder_offset [rad] joint side; rotor_inertia
    [kg m^2], viscous_motor [N m s/rad], coulomb_motor [N m] motor side (priors); torque_constant [N m/A].
    """

    name: str
    joint: int
    ratio: float
    coupling: tuple[tuple[int, float], ...] = ()
    encoder_offset: float = 0.0
    rotor_inertia: float = 0.0
    viscous_motor: float = 0.0
    coulomb_motor: float = 0.0
    torque_constant: float = 1.0

    @property
    def coupled(self) -> bool:
        """True when the motor angle depends on more than its own joint."""
        return any(c != 0.0 for _, c in self.coupling)


@dataclass(frozen=True)
class Term:
    """A torque beyond the rigid bodies (``[[terms]]``), linear in its coefficients ``values``.

    name; kind (:data:`TERM_KINDS`); joint [-] 1-based (None for a spring); functions (expressions);
    degree; knots [rad or m]; torques [N m]; function (expression); link_a, link_b [-] (0 = base);
    point_a, point_b [m] (3,); rest_length [m] or None; values (one per column, see
    :func:`tendyn.device.terms.term_columns`).
    """

    name: str
    kind: str
    joint: int | None = None
    functions: tuple[str, ...] = ()
    degree: int | None = None
    knots: tuple[float, ...] = ()
    torques: tuple[float, ...] = ()
    function: str | None = None
    link_a: int | None = None
    point_a: tuple | None = None
    link_b: int | None = None
    point_b: tuple | None = None
    rest_length: float | None = None
    values: tuple[float, ...] = ()

    @property
    def column_suffixes(self) -> tuple[str, ...]:
        """Suffixes of the term's identifiable columns (``<name>_<suffix>``; "" for an offset)."""
        if self.kind == "functions":
            return tuple(str(k + 1) for k in range(len(self.functions)))
        if self.kind == "polynomial":
            return tuple(str(k + 1) for k in range(self.degree))
        if self.kind == "table":
            return tuple(str(k + 1) for k in range(len(self.knots)))
        if self.kind == "spring":
            return ("k",) if self.rest_length is not None else ("k", "kl0")
        if self.kind == "offset":
            return ("",)
        return ()

    @property
    def column_names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_{s}" if s else self.name for s in self.column_suffixes)
