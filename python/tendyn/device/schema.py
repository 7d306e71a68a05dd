"""Device description, schema version 1: the data model and the field specifications.

Two halves:

* **Field specifications** (:class:`FieldSpec`): for every key a device file may hold, its type, unit,
  default and allowed range. :mod:`tendyn.device.load` validates against these tables, and
  ``docs/device-file.md`` documents the same fields (a test checks that every field is documented).
* **Data model**: frozen dataclasses built by :func:`tendyn.device.load_device`. All values are SI and
  radians; joints and transmissions are numbered from 1 in the file and in the ``joint`` / ``crosses``
  attributes, while the numpy arrays of :meth:`Device.routing_arrays` are indexed from 0.

Nothing here imports the compiled core; only the standard library and numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .base import Device, DeviceError  # noqa: F401 — DeviceError: its home is base.py (terms, rigid_body raise it)

SCHEMA_VERSION = 1
"""The schema version this package reads (``schema = 1`` at the top of the file)."""

CONVENTIONS = ("dh", "mdh", "urdf")
"""Kinematic conventions: standard DH, Khalil-Kleinfinger modified DH, or a URDF file."""

INERTIA_TOL = 1e-12
"""Tolerance [kg m^2] of the positive-semidefinite and triangle-inequality checks of inertias."""

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------------------------------------
# Field specifications
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FieldSpec:
    """Specification of one key of a device file.

    Parameters
    ----------
    name : str
        Key as written in the file.
    kind : str
        ``"str"``, ``"name"`` (a name: :data:`tendyn.text.NAME_DOMAIN`), ``"text"`` (free text, no control
        character but newline and tab: :func:`tendyn.text.text_problem`), ``"float"``, ``"int"``, ``"vec3"``
        (3 floats), ``"inertia"`` (6 floats), ``"int_list"``, ``"float_list"``, ``"str_list"``, ``"table"`` or
        ``"table_list"``.
        Integers are accepted where floats are expected; booleans never count as numbers.
    unit : str
        SI unit ("-" if dimensionless, "" for strings and tables).
    required : bool
        Whether the key must be present. When absent and not required, ``default`` is used.
    default : Any
        Default value of an optional key.
    lo, hi : float or None
        Bounds; ``lo_open`` / ``hi_open`` make them strict.
    abs_max : float or None
        Bound on the absolute value (``|x| <= abs_max``).
    nonzero : bool
        Zero is rejected (for signed radii).
    choices : tuple
        Allowed values (for strings and small integer enums).
    doc : str
        One-line description (also used in ``docs/device-file.md``).
    zero_hint : str
        Appended to the message when a value of 0 violates the range (e.g. singular routing).
    range_msg : str
        If set, the message used for any range violation (e.g. ``must be in (0, 1]``).
    max_items : int or None
        Most entries of a list (``*_list`` kinds): a file cannot make the tool allocate without bound.
    """

    name: str
    kind: str
    unit: str
    required: bool = True
    default: Any = None
    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    hi_open: bool = False
    abs_max: float | None = None
    nonzero: bool = False
    choices: tuple = ()
    doc: str = ""
    zero_hint: str = ""
    range_msg: str = ""
    max_items: int | None = None

    def range_text(self) -> str:
        """Human-readable allowed range, e.g. ``(0, 1]`` or ``|x| <= 10`` (empty if unbounded)."""
        if self.choices:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        parts = []
        if self.lo is not None and self.hi is not None:
            parts.append(f"{'(' if self.lo_open else '['}{_num(self.lo)}, {_num(self.hi)}{')' if self.hi_open else ']'}")
        elif self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {_num(self.lo)}")
        elif self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {_num(self.hi)}")
        if self.abs_max is not None:
            parts.append(f"|x| <= {_num(self.abs_max)}")
        if self.nonzero:
            parts.append("nonzero")
        if self.kind in ("float", "vec3", "inertia", "float_list"):
            parts.append("finite")
        if self.max_items is not None:
            parts.append(f"at most {self.max_items} entries")
        return ", ".join(parts)


def _num(x: float) -> str:
    if x == TWO_PI:
        return "2*pi"
    if float(x).is_integer():
        return str(int(x))
    return repr(x)


def _spec(name, kind, unit, doc, **kw) -> FieldSpec:
    """Short constructor for the tables below."""
    return FieldSpec(name=name, kind=kind, unit=unit, doc=doc, **kw)


TOP_FIELDS = (
    _spec("schema", "int", "-", "schema version of the file; must be 1", choices=(SCHEMA_VERSION,)),
    _spec("device", "table", "", "device identity"),
    _spec("kinematics", "table", "", "kinematic description"),
    _spec("transmissions", "table_list", "", "one entry per actuated joint (a device has [[transmissions]] "
      "or [[drives]], not both)", required=False),
    _spec("drives", "table_list", "", "elastic capstan drives, one per actuated joint (alternative to "
      "[[transmissions]])", required=False),
    _spec("actuators", "table_list", "", "geared motors, one per actuated joint, with an optional motor-to-joint "
      "coupling (alternative to [[transmissions]] and [[drives]])", required=False),
    _spec("terms", "table_list", "", "torques beyond the rigid bodies (springs, position-dependent torques, known "
      "torques, offsets): identifiable columns of the identification model, simulated by the twin",
      required=False, default=()),
)

DEVICE_KINDS = ("serial", "tendon_bench_2n")
"""Device kinds: a serial/tree mechanism described here, or the S1 tendon bench (its own loader)."""

ROUTINGS = ("one_per_joint", "n_plus_one")
"""How the ``[[transmissions]]`` share the joints: one cable (or antagonistic pair) per actuated joint, K square;
or N+1: n + 1 tendons on n actuated joints, K (n + 1, n) (issue 19; :mod:`tendyn.tendons`)."""

DEVICE_FIELDS = (
    _spec("name", "name", "", "device name (non-empty)"),
    _spec("description", "text", "", "free text", required=False, default=""),
    _spec("kind", "str", "", "device kind; \"tendon_bench_2n\" files are read by "
      "tendyn.device.tendon_bench.load_tendon_bench", required=False, default="serial", choices=DEVICE_KINDS),
    _spec("bandwidth_hz", "float", "Hz", "dynamic bandwidth of the joint motions (position loops); sets the "
      "default filters of identification (absent: 10 Hz)", required=False, lo=0.0, lo_open=True, hi=1e4),
    _spec("home_pose", "float_list", "rad", "joint positions where the hand and wall experiments start "
      "(pipeline s0, demo), one per joint, inside the limits (absent: the pose of best handle mobility on a "
      "grid of the joint ranges)", required=False),
    _spec("routing", "str", "", "how the [[transmissions]] share the joints: \"one_per_joint\" (one cable or "
      "antagonistic pair drives each actuated joint) or \"n_plus_one\" (n + 1 tendons share the n actuated joints)",
      required=False, default="one_per_joint", choices=ROUTINGS),
)

KINEMATICS_FIELDS = (
    _spec("convention", "str", "", "kinematic convention", choices=CONVENTIONS),
    _spec("gravity", "vec3", "m/s^2", "gravity vector in the base frame; norm <= 100"),
    _spec("urdf", "str", "", "URDF file, absolute or relative to the device file's folder; "
      "required with convention = \"urdf\", not allowed otherwise", required=False),
    _spec("joints", "table_list", "", "one entry per joint in order; required for \"dh\"/\"mdh\", "
      "not allowed for \"urdf\"", required=False),
    _spec("constraints", "table_list", "", "closed-loop constraints q_joint = sum(coef * q_active) + offset, "
      "one per passive non-cut joint (\"mdh\" only)", required=False, default=()),
    _spec("closure_tolerance", "float", "m", "largest gap the loader accepts between the two frames of a cut "
      "joint (sigma = 2) over poses inside the limits (closed loops, \"mdh\" only)", required=False,
      default=1e-6, lo=0.0, lo_open=True, hi=0.01),
)

CONSTRAINT_FIELDS = (
    _spec("joint", "int", "-", "the passive joint (mu = 0, sigma 0 or 1) this constraint determines", lo=1),
    _spec("terms", "table", "", "coefficients [-] on active joints, keys = joint numbers as strings, "
      "e.g. { \"2\" = -1.0, \"5\" = 1.0 }"),
    _spec("offset", "float", "rad or m", "constant term of the constraint", required=False, default=0.0,
      abs_max=10.0),
)

GRAVITY_MAX_NORM = 100.0

_LINK_FIELDS = (
    _spec("mass", "float", "kg", "mass of the link moved by this joint", lo=0.0, lo_open=True, hi=1000.0),
    _spec("com", "vec3", "m", "centre of mass in the link frame of this joint", abs_max=10.0),
    _spec("inertia", "inertia", "kg m^2",
      "[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] inertia-matrix entries about the COM, link frame; positive "
      "semidefinite and triangle inequalities (Ixx+Iyy >= Izz, ...), tolerance 1e-12", abs_max=1000.0),
)

DH_JOINT_FIELDS = (
    _spec("name", "name", "", "joint name, unique"),
    _spec("a", "float", "m", "link length a_i (standard DH)", abs_max=10.0),
    _spec("alpha", "float", "rad", "link twist alpha_i", abs_max=TWO_PI),
    _spec("d", "float", "m", "link offset d_i", abs_max=10.0),
    _spec("theta_offset", "float", "rad", "theta_i = q_i + theta_offset", required=False, default=0.0),
    _spec("lower", "float", "rad", "lower joint limit (< upper)"),
    _spec("upper", "float", "rad", "upper joint limit (> lower)"),
) + _LINK_FIELDS

MDH_JOINT_FIELDS = (
    _spec("name", "name", "", "frame/joint name, unique"),
    _spec("j", "int", "-", "frame number, 1-based; must equal the entry's position", lo=1),
    _spec("antecedent", "int", "-", "antecedent frame a(j); 0 = base; must be < j", lo=0),
    _spec("mu", "int", "-", "1 if the joint is actuated, else 0", choices=(0, 1)),
    _spec("sigma", "int", "-", "0 revolute, 1 prismatic, 2 cut joint / fixed frame", choices=(0, 1, 2)),
    _spec("gamma", "float", "rad", "gamma_j (Khalil-Kleinfinger)", required=False, default=0.0, abs_max=TWO_PI),
    _spec("b", "float", "m", "b_j", required=False, default=0.0, abs_max=10.0),
    _spec("alpha", "float", "rad", "alpha_j", abs_max=TWO_PI),
    _spec("d", "float", "m", "d_j", abs_max=10.0),
    _spec("theta_offset", "float", "rad", "theta_j = q_j + theta_offset (revolute)", required=False, default=0.0),
    _spec("r", "float", "m", "r_j (r_j = q_j + r for prismatic)", abs_max=10.0),
    _spec("lower", "float", "rad or m", "lower joint limit (< upper); optional for sigma = 2", required=False),
    _spec("upper", "float", "rad or m", "upper joint limit (> lower); optional for sigma = 2", required=False),
    _spec("mass", "float", "kg", "link mass; > 0 for an actuated joint, >= 0 for a passive one (mu = 0; "
      "e.g. the massless far side of a cut loop), optional (default 0) for sigma = 2",
      required=False, lo=0.0, hi=1000.0),
    _spec("com", "vec3", "m", "centre of mass in frame j (optional for sigma = 2)", required=False, abs_max=10.0),
    _spec("inertia", "inertia", "kg m^2", "as for \"dh\" (optional for sigma = 2)", required=False,
      abs_max=1000.0),
)

TRANSMISSION_FIELDS = (
    _spec("name", "name", "", "transmission name, unique"),
    _spec("joint", "int", "-", "driven joint number (1-based); every actuated joint is driven exactly once", lo=1),
    _spec("motor_radius", "float", "m", "motor pulley radius r_m", lo=0.0, lo_open=True, hi=1.0),
    _spec("crosses", "int_list", "-", "other joints the cable wraps, unique, != joint: before it (idle pulleys) "
      "or after it (a differential: the cable goes on past its driven joint)", required=False, default=()),
    _spec("crossed_radii", "float_list", "m", "signed pulley radius per crossed joint (sign = winding direction)",
      required=False, default=(), abs_max=1.0, nonzero=True),
    _spec("driven_radius", "float", "m", "driven pulley radius, signed (winding direction); 0 = the cable does not "
      "wrap its joint (a zero diagonal: the routing must stay invertible)", abs_max=1.0),
    _spec("reducer_ratio", "float", "-", "reducer ratio n in the driven pulley (generalised radius = "
      "driven_radius * reducer_ratio, S0 footnote 1)", required=False, default=1.0, lo=1.0, hi=1e4),
    _spec("reducer_efficiency", "float", "-", "direct efficiency eta_d of the reducer (<= 0.5: self-locking)",
      required=False, default=1.0, lo=0.0, lo_open=True, hi=1.0, range_msg="must be in (0, 1]"),
    _spec("pretension", "float", "N", "cable pretension (of each cable of an antagonistic pair)", required=False,
      default=0.0, lo=0.0, hi=1e6),
    _spec("antagonistic", "bool", "-", "the motor drives a pair of cables wound in opposite directions over the "
      "same pulleys (2N routing): each cable keeps pretension >= the minimum reported, losses per cable",
      required=False, default=False),
    _spec("friction", "table_list", "", "one entry per branch (the largest of `joint` and `crosses` entries)"),
    _spec("bearings", "table_list", "", "optional per-branch bearings, same length as friction; {} = none",
      required=False),
    _spec("motor", "table", "", "motor data"),
    _spec("sensors", "table", "", "sensor data"),
)

FRICTION_FIELDS = (
    _spec("tau0", "float", "N", "Coulomb friction force of the branch (eq. 12)", lo=0.0, hi=1e6),
    _spec("nu", "float", "N s/m", "viscous friction of the branch (eq. 12)", lo=0.0, hi=1e6),
    _spec("beta", "float", "-", "tension-proportional loss of the branch (eq. 11)", required=False, default=0.0,
      lo=0.0, hi=1.0, hi_open=True, range_msg="must be in [0, 1)"),
)

BEARING_FIELDS = (
    _spec("count", "int", "-", "number of bearings on the branch", lo=0),
    _spec("radius", "float", "m", "pulley radius over the bearings", lo=0.0, lo_open=True, hi=1.0),
    _spec("wrap", "float", "rad", "cable wrap angle", lo=0.0, lo_open=True, hi=TWO_PI,
      range_msg="must be in (0, 2*pi]"),
    _spec("static_coefficient", "float", "m", "bearing friction torque per newton of radial load at break-away "
      "(S0 eq. 7 alpha)", lo=0.0, hi=1.0),
    _spec("dynamic_coefficient", "float", "m", "bearing friction torque per newton of radial load while turning "
      "(S0 eq. 7 beta)", lo=0.0, hi=1.0),
    _spec("h0", "float", "N m", "speed-independent torque (eq. 8)", lo=0.0, hi=1e3),
    _spec("h1", "float", "N m (rad/s)^(-2/3)", "speed-dependent coefficient (eq. 8)", lo=0.0, hi=1e3),
    _spec("n0", "float", "rad/s", "speed threshold (eq. 8)", lo=0.0, hi=1e6),
)

MOTOR_FIELDS = (
    _spec("torque_constant", "float", "N m/A", "motor torque constant k_t", lo=0.0, lo_open=True, hi=1e3),
    _spec("rotor_inertia", "float", "kg m^2", "rotor inertia (motor side)", lo=0.0, hi=1e3),
    _spec("continuous_torque", "float", "N m", "continuous torque (motor side)", lo=0.0, lo_open=True, hi=1e5),
    _spec("peak_torque", "float", "N m", "peak torque (motor side), >= continuous_torque", lo=0.0, lo_open=True,
      hi=1e5),
)

SENSOR_FIELDS = (
    _spec("encoder_counts", "int", "counts/rev", "encoder counts per motor revolution after decoding", lo=1),
    _spec("current_noise", "float", "A", "rms current measurement noise", lo=0.0, hi=1e3),
)

DRIVE_FIELDS = (
    _spec("name", "name", "", "drive name, unique (default \"drive<joint>\")", required=False),
    _spec("joint", "int", "-", "driven joint number (1-based, actuated); every actuated joint is driven "
      "exactly once", lo=1),
    _spec("ratio", "float", "-", "capstan ratio N: joint speed * N = motor speed", lo=0.0, lo_open=True,
      hi=1e4),
    _spec("stiffness_motor", "float", "N m/rad", "capstan (cable) stiffness K_T seen at the motor",
      lo=0.0, lo_open=True, hi=1e9),
    _spec("damping_motor", "float", "N m s/rad", "capstan damping seen at the motor", required=False,
      default=0.0, lo=0.0, hi=1e6),
    _spec("coulomb_motor", "float", "N m", "Coulomb friction at the motor (joint side: N * coulomb_motor)",
      required=False, default=0.0, lo=0.0, hi=1e6),
    _spec("viscous_motor", "float", "N m s/rad", "viscous friction at the motor (joint side: N^2 * "
      "viscous_motor)", required=False, default=0.0, lo=0.0, hi=1e6),
    _spec("offset_joint", "float", "N m", "constant torque offset seen at the joint (any sign)",
      required=False, default=0.0, abs_max=1e6),
    _spec("servo_stiffness_motor", "float", "N m/rad", "servo (\"electric\") stiffness K_E at the motor; "
      "absent = not modelled", required=False, lo=0.0, hi=1e9),
    _spec("motor", "table", "", "motor data, as [transmissions.motor]"),
    _spec("sensors", "table", "", "sensor data, as [transmissions.sensors]"),
)

ACTUATOR_FIELDS = (
    _spec("name", "name", "", "actuator (motor) name, unique (default \"motor<joint>\")", required=False),
    _spec("joint", "int", "-", "the joint this motor drives (1-based, actuated); every actuated joint is "
      "driven exactly once", lo=1),
    _spec("ratio", "float", "-", "gear ratio N (signed): motor angle = N * (q_joint + sum(coupling * q_k))",
      abs_max=1e5, nonzero=True),
    _spec("coupling", "table", "", "coupling on other actuated joints, keys = joint numbers as strings, "
      "values [-]: q_motor = N * (q_joint + sum(coef * q_k)), e.g. { \"5\" = 1.0 } for the TX40 wrist",
      required=False, default=None),
    _spec("encoder_offset", "float", "rad", "joint-side zero offset: q_joint = (G^-1 q_motor)_joint + "
      "encoder_offset", required=False, default=0.0, abs_max=100.0),
    _spec("rotor_inertia", "float", "kg m^2", "rotor inertia (motor side), a prior", required=False,
      default=0.0, lo=0.0, hi=1e3),
    _spec("viscous_motor", "float", "N m s/rad", "viscous friction at the motor, a prior", required=False,
      default=0.0, lo=0.0, hi=1e6),
    _spec("coulomb_motor", "float", "N m", "Coulomb friction at the motor, a prior", required=False,
      default=0.0, lo=0.0, hi=1e6),
    _spec("torque_constant", "float", "N m/A", "motor torque constant k_t (to import currents)",
      required=False, default=1.0, lo=0.0, lo_open=True, hi=1e3),
)

from .terms import MAX_EXPRESSION_CHARS, MAX_EXPRESSION_DEPTH, MAX_EXPRESSION_NODES, MAX_KNOTS, MAX_LITERAL  # noqa: E402

TERM_KINDS = ("functions", "polynomial", "table", "spring", "offset", "known")
"""Kinds of ``[[terms]]`` entry (docs/device-file.md): τ linear in given functions of q, a polynomial or a
table in the joint's q, a spring between two points of two links, a constant, or a known torque (no column)."""

TERM_FIELDS = (
    _spec("name", "name", "", "term name, unique; letters, digits and _ (its columns are named after it: "
      "<name>_1, <name>_2, ... or <name>_k, <name>_kl0 for a spring, <name> for an offset)"),
    _spec("kind", "str", "", "what the term is", choices=TERM_KINDS),
    _spec("joint", "int", "-", "the joint the torque acts on (1-based; not for \"spring\", which acts on every "
      "joint between its two links)", required=False, lo=1),
    _spec("functions", "str_list", "", "\"functions\": expressions in q (this joint) and q1, q2, ... (file joint "
      "numbers) with + - * / ** and sin cos tan exp log sqrt abs tanh sign pi, e.g. [\"cos(q)\", \"sin(q)\"]; "
      "the torque is sum(value_k * function_k) [N m, N at a prismatic joint]; float arithmetic, at most "
      f"{MAX_EXPRESSION_CHARS} characters, {MAX_EXPRESSION_NODES} nodes, depth {MAX_EXPRESSION_DEPTH}, numbers "
      f"within ±{MAX_LITERAL:g}, finite over the joint's range", required=False, default=(), max_items=32),
    _spec("degree", "int", "-", "\"polynomial\": torque = sum_{k=1..degree} value_k * q^k (the constant is the "
      "joint's OFFSET)", required=False, lo=1, hi=12),
    _spec("knots", "float_list", "rad or m", "\"table\" and tabulated \"known\": increasing positions of the "
      "joint; between knots the torque is linear, beyond the ends constant", required=False, default=(),
      max_items=MAX_KNOTS),
    _spec("torques", "float_list", "N m", "tabulated \"known\": the torque at each knot", required=False,
      default=(), max_items=MAX_KNOTS),
    _spec("function", "str", "", "\"known\": the torque [N m] as an expression (as for functions)",
      required=False),
    _spec("link_a", "int", "-", "\"spring\": the link of the first end (its joint number; 0 = the base)",
      required=False, lo=0),
    _spec("point_a", "vec3", "m", "\"spring\": the first end in link_a's frame (as `com`)", required=False,
      abs_max=10.0),
    _spec("link_b", "int", "-", "\"spring\": the link of the second end", required=False, lo=0),
    _spec("point_b", "vec3", "m", "\"spring\": the second end in link_b's frame", required=False, abs_max=10.0),
    _spec("rest_length", "float", "m", "\"spring\": free length l0 when known (one column, the stiffness k "
      "[N/m]); absent: two columns, k [N/m] and k*l0 [N]", required=False, lo=0.0, hi=10.0),
    _spec("values", "float_list", "", "the term's coefficients, one per column (units of the columns, "
      "docs/device-file.md): a prior, and the twin's truth (absent: 0)", required=False, default=(),
      max_items=MAX_KNOTS),
)

ALL_FIELD_TABLES = {
    "": TOP_FIELDS,
    "device": DEVICE_FIELDS,
    "kinematics": KINEMATICS_FIELDS,
    "kinematics.joints (dh)": DH_JOINT_FIELDS,
    "kinematics.joints (mdh)": MDH_JOINT_FIELDS,
    "transmissions": TRANSMISSION_FIELDS,
    "transmissions.friction": FRICTION_FIELDS,
    "transmissions.bearings": BEARING_FIELDS,
    "transmissions.motor": MOTOR_FIELDS,
    "transmissions.sensors": SENSOR_FIELDS,
    "kinematics.constraints": CONSTRAINT_FIELDS,
    "drives": DRIVE_FIELDS,
    "drives.motor": MOTOR_FIELDS,
    "drives.sensors": SENSOR_FIELDS,
    "actuators": ACTUATOR_FIELDS,
    "terms": TERM_FIELDS,
}
"""Every field table, keyed by the section it describes (used by docs checks)."""


# ----------------------------------------------------------------------------------------------------------
# Data model
# ----------------------------------------------------------------------------------------------------------

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


BEARING_PREFIX = "bearing_"
"""A bearing field ``x`` of the device file is the routing array / core field ``bearing_x``."""

BEARING_ARRAY_NAMES = tuple(spec.name for spec in BEARING_FIELDS)
"""Keys of a ``bearings`` entry, in order (derived from :data:`BEARING_FIELDS`)."""

NO_BEARING = {"radius": 1.0}
"""Array values of a branch without bearings where not 0 (a radius of 1 m: no division by zero)."""


@dataclass(frozen=True)
class ModelField:
    """One field of the core transmission model (``tendyn._core.TransmissionModel``), derived from the
    device-file field tables: the one route from a TOML key to the C++ step.

    Attributes
    ----------
    name : str
        Core field name = key of :meth:`Device.routing_arrays` = model-file key.
    dims : int
        1: (m,) per transmission; 2: (m, n), [i, j] = joint j (``K``) or branch j of transmission i.
    unit : str
        SI unit (as in the field table it comes from).
    toml : str
        Where it comes from in the device file (``transmissions.bearings.static_coefficient``).
    attribute : str
        The dataclass attribute that holds it (``Bearing.static_coefficient``).
    default : float
        Value when the file does not give it (lossless, no bearing).
    """

    name: str
    dims: int
    unit: str
    toml: str
    attribute: str
    default: float


def _spec_default(spec: FieldSpec) -> float:
    return float(spec.default) if isinstance(spec.default, (int, float)) else 0.0


_TRANSMISSION_SPECS = {spec.name: spec for spec in TRANSMISSION_FIELDS}

TRANSMISSION_MODEL_FIELDS: tuple[ModelField, ...] = (
    ModelField("motor_radius", 1, _TRANSMISSION_SPECS["motor_radius"].unit, "transmissions.motor_radius",
               "TransmissionSpec.motor_radius", 0.0),
    ModelField("K", 2, "m", "transmissions.crosses, crossed_radii, driven_radius * reducer_ratio",
               "TransmissionSpec.crosses, crossed_radii, generalized_radius", 0.0),
) + tuple(
    ModelField(name, 1, _TRANSMISSION_SPECS[name].unit, f"transmissions.{name}", f"TransmissionSpec.{name}",
               _spec_default(_TRANSMISSION_SPECS[name]))
    for name in ("driven_radius", "reducer_ratio", "reducer_efficiency", "pretension")
) + tuple(
    ModelField(spec.name, 2, spec.unit, f"transmissions.friction.{spec.name}", f"BranchFriction.{spec.name}",
               _spec_default(spec))
    for spec in FRICTION_FIELDS
) + tuple(
    ModelField(BEARING_PREFIX + spec.name, 2, spec.unit, f"transmissions.bearings.{spec.name}",
               f"Bearing.{spec.name}", NO_BEARING.get(spec.name, 0.0))
    for spec in BEARING_FIELDS
)
"""Every field of the core transmission model, in the order of the C++ parameter table
(``TENDYN_TRANSMISSION_FIELDS`` in ``include/tendyn/routing.hpp``; a test checks they agree). The routing
arrays, the Python -> C++ fill, the friction-free model, the twin's truth and the docs derive from it."""

LOSS_FIELD_NAMES = tuple(f.name for f in TRANSMISSION_MODEL_FIELDS if f.dims == 2 and f.name != "K")
"""The per-branch loss and bearing fields (everything but the routing) of the core model."""


@dataclass(frozen=True, eq=False)
class SerialDevice(Device):
    """A validated serial (or tree) device description (see :func:`tendyn.device.load_device`).

    name, description : str
    path : Path of the device file
    kinematics : :class:`Kinematics`
    transmissions : tuple of :class:`TransmissionSpec`, sorted by driven joint (empty for a drive device); an N+1
        routing holds n + 1 of them, those ending on the same joint in the file's order
    routing : "one_per_joint" or "n_plus_one" (``[device] routing``)
    drives : tuple of :class:`Drive`, sorted by driven joint (empty for a transmission device)
    actuators : tuple of :class:`Actuator` in the file's order: motor i is the i-th ``[[actuators]]`` entry
    kind : "serial" (class attribute; see :class:`tendyn.device.base.Device`)
    experiments : the experiments of a chain twin (class attribute)
    """

    name: str
    description: str
    path: Path
    kinematics: Kinematics
    transmissions: tuple[TransmissionSpec, ...] = field(default_factory=tuple)
    drives: tuple[Drive, ...] = field(default_factory=tuple)
    actuators: tuple[Actuator, ...] = field(default_factory=tuple)
    bandwidth_hz: float | None = None
    home_pose: tuple | None = None
    routing: str = "one_per_joint"
    terms: tuple[Term, ...] = field(default_factory=tuple)
    kind: ClassVar[str] = "serial"
    experiments: ClassVar[tuple[str, ...]] = ("constant-velocity", "exciting", "blocked-link", "stepped-sine",
                                              "swept-sine")

    @property
    def source(self) -> str:
        """The device file, as text."""
        return str(self.path)

    @property
    def n_joints(self) -> int:
        """Number of joints of the kinematic description."""
        return self.kinematics.n_joints

    @property
    def n_transmissions(self) -> int:
        return len(self.transmissions)

    @property
    def n_plus_one(self) -> bool:
        """True for an N+1 routing (``[device] routing = "n_plus_one"``): n + 1 tendons on n actuated joints."""
        return self.routing == "n_plus_one"

    def motor_joint_matrix(self) -> np.ndarray:
        """G (n_motors, n_active) [rad/rad] with q_motor = G q_active (active joints in tree order).

        The one matrix the three actuation kinds build, so identification and a later generalisation
        (rectangular couplings, differentials) share it: ``[[actuators]]`` give G = diag(N) (I + coupling);
        ``[[drives]]`` G = diag(N); ``[[transmissions]]`` G = R_m^-1 K restricted to the active joints
        (cable routing). The motor torques y map to joint torques as tau = G^T y (virtual work).
        """
        active = [num for num, js in enumerate(self.kinematics.joints, start=1) if js.actuated and js.sigma != 2]
        col = {num: k for k, num in enumerate(active)}
        if self.actuators:
            G = np.zeros((len(self.actuators), len(active)))
            for i, a in enumerate(self.actuators):
                G[i, col[a.joint]] = a.ratio
                for jn, coef in a.coupling:
                    G[i, col[jn]] += a.ratio * coef
            return G
        if self.drives:
            G = np.zeros((len(self.drives), len(active)))
            for i, d in enumerate(self.drives):
                G[i, col[d.joint]] = d.ratio
            return G
        arr = self.routing_arrays()
        K = arr["K"][:, [num - 1 for num in active]]
        return K / arr["motor_radius"][:, None]

    def joint_offsets(self) -> np.ndarray:
        """Encoder zero offsets [rad] per active joint (0 unless ``[[actuators]]`` give them)."""
        active = [num for num, js in enumerate(self.kinematics.joints, start=1) if js.actuated and js.sigma != 2]
        off = {a.joint: a.encoder_offset for a in self.actuators}
        return np.array([off.get(num, 0.0) for num in active])

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.kinematics.joints)

    def square_routing_arrays(self, what: str) -> dict[str, np.ndarray]:
        """:meth:`routing_arrays` of a device with one cable (or antagonistic pair) per joint, for ``what`` (the
        square statics with losses, :meth:`tendyn.transmission.Transmission.from_device`); an N+1 device raises
        DeviceError naming ``what`` (:func:`require_one_per_joint`)."""
        require_one_per_joint(self, what)
        return self.routing_arrays()

    def routing_arrays(self) -> dict[str, np.ndarray]:
        """The routing and friction data as numpy arrays, 0-based.

        Rows are transmissions (sorted by driven joint), columns are joints; with one transmission per
        joint (every "dh" device) the matrices are square (n, n); lower-triangular for a serial routing, with
        entries above the diagonal for a differential (a cable that wraps joints after the one it drives).
        An antagonistic pair (``antagonistic = true``) is one row of net tension u = T_a − T_b: its two cables
        slide in opposite directions, so their losses add, and while both are taut (T_a + T_b = 2P) the
        tension-proportional part is a constant: tau0 = 2 τ₀ + 2 β P, nu = 2 ν, beta = 0 per branch.

        Returns
        -------
        dict of str to ndarray
            ``motor_radius`` (m,) [m]; ``K`` (m, n) [m] with K[i, j] the signed idle-pulley radius of
            transmission i at crossed joint j, K[i, joint_i] = generalised radius (driven_radius *
            reducer_ratio), 0 elsewhere, so that R_m q_m = K q; ``driven_radius``, ``reducer_ratio``,
            ``reducer_efficiency``, ``pretension`` (m,); ``tau0`` [N], ``nu`` [N s/m], ``beta`` [-] (m, n)
            with [i, b] = branch b of transmission i (zero past the last joint it wraps); ``bearing_count``,
            ``bearing_radius``, ``bearing_wrap``, ``bearing_static_coefficient``,
            ``bearing_dynamic_coefficient``, ``bearing_h0``, ``bearing_h1``, ``bearing_n0`` (m, n), zero where
            there is no bearing except ``bearing_radius`` = 1.0 there (no division by zero). The keys and
            their order are those of :data:`TRANSMISSION_MODEL_FIELDS` (the core model's fields).
        """
        n = self.n_joints
        m = self.n_transmissions
        out: dict[str, np.ndarray] = {}
        for f in TRANSMISSION_MODEL_FIELDS:
            out[f.name] = np.full((m, n) if f.dims == 2 else (m,), f.default, dtype=float)
        for i, t in enumerate(self.transmissions):
            for f in TRANSMISSION_MODEL_FIELDS:
                if f.dims == 1:
                    out[f.name][i] = getattr(t, f.name)
            for jn, rad in zip(t.crosses, t.crossed_radii):
                out["K"][i, jn - 1] = rad
            out["K"][i, t.joint - 1] = t.generalized_radius
            for b, fr in enumerate(t.friction):
                for spec in FRICTION_FIELDS:
                    out[spec.name][i, b] = getattr(fr, spec.name)
                if t.antagonistic:  # the pair as one transmission of net tension (docs/device-file.md)
                    out["tau0"][i, b] = 2.0 * fr.tau0 + 2.0 * fr.beta * t.pretension
                    out["nu"][i, b] = 2.0 * fr.nu
                    out["beta"][i, b] = 0.0
            for b, br in enumerate(t.bearings):
                if br is None:
                    continue
                for name in BEARING_ARRAY_NAMES:
                    out[BEARING_PREFIX + name][i, b] = getattr(br, name)
        return out


    def drive_routing_arrays(self) -> dict[str, np.ndarray]:
        """The capstan ``[[drives]]`` as one-branch cable transmissions (S0 eq. 17 with one branch per drive), for
        the statics with losses and the compensator (issue 40).

        Drive k (in file order: the simulator's and the active map's order) is transmission k with the motor
        radius r_m = :data:`DRIVE_MOTOR_RADIUS` and K[k, k] = N_k r_m, so q_k = q_m,k / N_k and the lossless motor
        torque is τ_k / N_k; the branch slides at Ṡ = r_m q̇_m, so the branch law Δτ = τ0 sgn(Ṡ) + ν Ṡ
        (losses.hpp) times r_m is the drive's motor friction C_m0 sgn(q̇_m) + ν_m q̇_m with τ0 = C_m0 / r_m [N],
        ν = ν_m / r_m² [N·s/m]. Not modelled here (the twin has
        them): the cable's elasticity and damping (the compensator reads the motor encoders, q = q_m / N) and
        ``offset_joint``. Returns the keys of :meth:`routing_arrays` with rows = columns = drives.
        """
        m = len(self.drives)
        out: dict[str, np.ndarray] = {}
        for f in TRANSMISSION_MODEL_FIELDS:
            out[f.name] = np.full((m, m) if f.dims == 2 else (m,), f.default, dtype=float)
        r = DRIVE_MOTOR_RADIUS
        out["motor_radius"][:] = r
        out["K"][:] = np.diag([d.ratio * r for d in self.drives])
        out["driven_radius"][:] = [d.ratio * r for d in self.drives]
        out["reducer_ratio"][:] = 1.0
        out["reducer_efficiency"][:] = 1.0
        out["pretension"][:] = 0.0
        out["tau0"][:] = np.diag([d.coulomb_motor / r for d in self.drives])
        out["nu"][:] = np.diag([d.viscous_motor / r ** 2 for d in self.drives])
        return out


DRIVE_MOTOR_RADIUS = 0.01
"""Motor radius [m] of the one-branch transmission a capstan drive is compensated as
(:meth:`SerialDevice.drive_routing_arrays`): any value gives the same motor torques; 1 cm keeps the driven radius
N r_m inside the schema's 1 m bound for ratios up to 100."""


def require_one_per_joint(device, what: str) -> None:
    """Refuse ``what`` (a simulator, an export, the compiled device …) on an N+1 device, with a DeviceError (the
    command line's exit 2) naming the limit: the square statics with losses of the core (routing.hpp, losses.hpp)
    and everything built on them need one cable per joint; N+1 tendons have their own core (include/tendyn/tendons.hpp,
    :mod:`tendyn.tendons`) and simulator drive (sim.hpp, DriveKind::Tendons)."""
    if getattr(device, "routing", None) == "n_plus_one":
        raise DeviceError(f"{what}: one cable (or antagonistic pair) per joint needed, K square; this device's "
                          f"{len(device.transmissions)} tendons share its {device.n_joints} joints (N+1). N+1 "
                          "devices are read, checked and shown (`tendyn routing show`), simulated (`tendyn simulate`: "
                          "constant-velocity S2, exciting) and their tendon tensions computed by "
                          "tendyn.tendons.Tendons; the S0 compensator, identification and the exports do not take "
                          "them yet (docs/device-file.md, 'N+1 routings')",
                          file=device.path.name if getattr(device, "path", None) else None, field="device.routing")
