"""The device file's field specifications (schema version 1): for every key a device file may hold, its type,
unit, default and allowed range (:class:`FieldSpec`), one table per section. :mod:`tendyn.device.load`
validates against these tables, and ``docs/device-file.md`` documents the same fields (a test checks that every
field is documented). Only the standard library."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .terms import MAX_EXPRESSION_CHARS, MAX_EXPRESSION_DEPTH, MAX_EXPRESSION_NODES, MAX_KNOTS, MAX_LITERAL

SCHEMA_VERSION = 1
"""The schema version this package reads (``schema = 1`` at the top of the file)."""

CONVENTIONS = ("dh", "mdh", "urdf")
"""Kinematic conventions: standard DH, Khalil-Kleinfinger modified DH, or a URDF file."""

INERTIA_TOL = 1e-12
"""Tolerance [kg m^2] of the positive-semidefinite and triangle-inequality checks of inertias."""

TWO_PI = 2.0 * math.pi

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
