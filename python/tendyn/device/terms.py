"""Torques beyond the rigid bodies (``[[terms]]`` of a device file): the one place they are evaluated.

Every term is linear in its coefficients: τ_term(q) = Φ(q) θ, with Φ the term's columns (the joint torques of a
unit coefficient). The identification model appends Φ to its regressor (identifiable columns, with units and
%σ like the link parameters); the twin simulator tabulates Φ θ (θ = the file's ``values``, its truth) and
applies it at every step; a ``known`` term has no column: its torque is subtracted from the measured one.

Sign: a term is a torque the actuators must supply, like the rigid body's: τ_motor,joint = W X + Φ θ.

Kinds (docs/device-file.md):

* ``functions``: Φ_k = f_k(q) at ``joint`` (e.g. cos q, sin q of a gravity spring).
* ``polynomial``: Φ_k = q_joint^k, k = 1..degree.
* ``table``: Φ_k = hat function of knot k (linear interpolation, constant beyond the ends): θ_k is the torque
  at knot k.
* ``spring``: a spring between point a of link a and point b of link b, tension k (l − l0) along the line; its
  joint torques are τ = −(∂l/∂q)ᵀ k (l − l0) with the sign of a torque the actuators supply… the actuators
  supply −(the spring's generalised force): τ = k (l − l0) ∂l/∂q, so the columns are l ∂l/∂q (θ = k [N/m]) and
  −∂l/∂q (θ = k l0 [N]), or (l − l0) ∂l/∂q when l0 is given. ∂l/∂q = uᵀ (J_b − J_a), u = (p_b − p_a)/l.
* ``offset``: Φ = 1 at ``joint``.
* ``known``: no column; the torque f(q) or the table (knots, torques).
"""

from __future__ import annotations

import ast
import math

import numpy as np

__all__ = ["EXPRESSION_FUNCTIONS", "check_expression", "check_values", "evaluate_expression", "TermModel",
           "MAX_EXPRESSION_CHARS", "EXPRESSION_MAX_CHARS", "MAX_EXPRESSION_NODES", "MAX_EXPRESSION_DEPTH", "MAX_LITERAL", "MAX_KNOTS"]

EXPRESSION_FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
                        "sqrt": np.sqrt, "abs": np.abs, "tanh": np.tanh, "sign": np.sign}
"""Functions an expression of a term may call (numpy, elementwise)."""

_BINOPS = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide,
           ast.Pow: np.power}
_UNOPS = {ast.USub: np.negative, ast.UAdd: np.positive}

MAX_EXPRESSION_CHARS = 400
"""Longest expression text [characters]; checked before the text is parsed (a 100k-long chain is refused
without building its tree)."""
EXPRESSION_MAX_CHARS = MAX_EXPRESSION_CHARS
"""The same limit under the name issue 36 gave it."""
MAX_EXPRESSION_NODES = 200
"""Most syntax-tree nodes (names, numbers, operators, calls) in one expression."""
MAX_EXPRESSION_DEPTH = 20
"""Deepest nesting of operators and calls in one expression."""
MAX_LITERAL = 1e9
"""Largest magnitude of a number written in an expression [-]: every number is a float (no unbounded integer
arithmetic), and a power tower of floats overflows to a refusal at load instead of spinning."""


def _depth(node: ast.AST, limit: int) -> int:
    """Nesting depth of ``node``, iteratively (a deep tree cannot exhaust the interpreter's stack)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        n, d = stack.pop()
        deepest = max(deepest, d)
        if deepest > limit:
            return deepest
        stack.extend((c, d + 1) for c in ast.iter_child_nodes(n)
                     if not isinstance(c, (ast.Load, ast.operator, ast.unaryop)))
    return deepest


def check_expression(text: str, n_joints: int) -> set[int]:
    """Raise ValueError unless ``text`` is an expression of q, q1…q<n_joints>, numbers, pi and
    :data:`EXPRESSION_FUNCTIONS` with + − × / **, within the limits (:data:`MAX_EXPRESSION_CHARS` characters,
    :data:`MAX_EXPRESSION_NODES` nodes, depth :data:`MAX_EXPRESSION_DEPTH`, numbers of magnitude at most
    :data:`MAX_LITERAL`); returns the joint numbers it reads (0 for plain ``q``). Its values are checked by
    :func:`check_values` (finite over the joint's range)."""
    if not isinstance(text, str):
        raise ValueError("must be a string")
    if len(text) > MAX_EXPRESSION_CHARS:
        raise ValueError(f"{len(text)} characters, more than the {MAX_EXPRESSION_CHARS} an expression may have")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ValueError(f"not an expression: {getattr(exc, 'msg', None) or exc}") from None
    nodes = list(ast.walk(tree))
    n_nodes = sum(not isinstance(n, (ast.Load, ast.operator, ast.unaryop)) for n in nodes)
    if n_nodes > MAX_EXPRESSION_NODES:
        raise ValueError(f"{n_nodes} terms and operators, more than the {MAX_EXPRESSION_NODES} allowed")
    if _depth(tree, MAX_EXPRESSION_DEPTH) > MAX_EXPRESSION_DEPTH:
        raise ValueError(f"nested deeper than {MAX_EXPRESSION_DEPTH} levels")
    used: set[int] = set()
    for node in nodes:
        if isinstance(node, (ast.Expression, ast.Load, ast.operator, ast.unaryop)):
            if isinstance(node, (ast.operator, ast.unaryop)) and type(node) not in _BINOPS and \
                    type(node) not in _UNOPS:
                raise ValueError(f"operator {type(node).__name__} not allowed (+ - * / ** only)")
            continue
        if isinstance(node, (ast.BinOp, ast.UnaryOp)):
            continue
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            try:
                x = float(node.value)
            except OverflowError:
                x = math.inf
            if not math.isfinite(x) or abs(x) > MAX_LITERAL:
                raise ValueError(f"the number {str(node.value)[:20]}{'…' if len(str(node.value)) > 20 else ''} is "
                                 f"beyond ±{MAX_LITERAL:g} (the largest number an expression may hold)")
            continue
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in EXPRESSION_FUNCTIONS or node.keywords \
                    or len(node.args) != 1:
                raise ValueError("calls allowed: one argument to " + ", ".join(EXPRESSION_FUNCTIONS))
            continue
        if isinstance(node, ast.Name):
            name = node.id
            if name in EXPRESSION_FUNCTIONS or name == "pi":
                continue
            if name == "q":
                used.add(0)
                continue
            if name.startswith("q") and name[1:].isdigit() and 1 <= int(name[1:]) <= n_joints:
                used.add(int(name[1:]))
                continue
            raise ValueError(f"unknown name {name!r} (q, q1…q{n_joints}, pi, "
                             + ", ".join(EXPRESSION_FUNCTIONS) + ")")
        raise ValueError(f"{type(node).__name__} not allowed in an expression")
    return used


def _evaluate(node: ast.AST, env: dict):
    """Float-only evaluation of a checked tree (no ``eval``, no Python integers: numbers become float64)."""
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, env)
    if isinstance(node, ast.Constant):
        return np.float64(node.value)
    if isinstance(node, ast.Name):
        return env[node.id]
    if isinstance(node, ast.UnaryOp):
        return _UNOPS[type(node.op)](_evaluate(node.operand, env))
    if isinstance(node, ast.BinOp):
        return _BINOPS[type(node.op)](_evaluate(node.left, env), _evaluate(node.right, env))
    if isinstance(node, ast.Call):
        return EXPRESSION_FUNCTIONS[node.func.id](_evaluate(node.args[0], env))
    raise ValueError(f"{type(node).__name__} not allowed in an expression")  # pragma: no cover - checked


def evaluate_expression(text: str, q_own, q_by_number: dict, *, strict: bool = False) -> np.ndarray:
    """Value of a checked expression on samples: ``q_own`` (n,) the term's joint, ``q_by_number`` file joint
    number → (n,) positions [rad or m]. Float arithmetic only; with ``strict`` a division by zero, an overflow
    or an invalid operation (0 ** −1, log of a negative number) raises FloatingPointError."""
    env = dict(EXPRESSION_FUNCTIONS, pi=np.float64(math.pi), q=np.asarray(q_own, float))
    env.update({f"q{k}": np.asarray(v, float) for k, v in q_by_number.items()})
    with np.errstate(all="raise" if strict else "ignore"):
        out = _evaluate(ast.parse(text.strip(), mode="eval"), env)
    return np.broadcast_to(np.asarray(out, float), np.shape(q_own)).copy()


def joint_range(joint, margin: float = 0.5) -> tuple[float, float]:
    """The span [rad or m] over which the terms of a joint are checked at load and tabulated by the twin: its
    limits (absent: ±π) widened by ``margin`` of their width on each side."""
    lo = joint.lower if joint.lower is not None else -np.pi
    hi = joint.upper if joint.upper is not None else np.pi
    return lo - margin * (hi - lo), hi + margin * (hi - lo)


def check_values(text: str, own: int, ranges: dict, n_samples: int = 257) -> None:
    """Raise ValueError unless the checked expression ``text`` is finite, without a division by zero, an overflow
    or an invalid operation, on ``n_samples`` positions of its joint ``own`` spanning its range and the other
    joints at seeded positions in theirs (``ranges``: joint number → (lo, hi) [rad or m], the ranges the twin
    tabulates). Evaluated once, at load."""
    rng = np.random.default_rng(0)
    lo, hi = ranges[own]
    q_own = np.linspace(lo, hi, n_samples)
    byn = {num: (q_own if num == own else rng.uniform(a, b, n_samples)) for num, (a, b) in ranges.items()}
    try:
        x = evaluate_expression(text, q_own, byn, strict=True)
    except FloatingPointError as exc:
        what = {"divide": "divides by zero", "overflow": "overflows", "invalid": "is undefined"}
        kind = next((v for k, v in what.items() if k in str(exc)), "fails")
        raise ValueError(f"{kind} for joint {own} in [{lo:.4g}, {hi:.4g}] (float arithmetic; e.g. 0 ** -1, "
                         f"a power tower, log of 0)") from None
    if not np.all(np.isfinite(x)):
        raise ValueError(f"is not finite for joint {own} in [{lo:.4g}, {hi:.4g}]")


MAX_KNOTS = 512
"""Most knots of a ``table`` or tabulated ``known`` term (the twin tabulates n_samples × knots weights)."""


def hat_basis(x, knots) -> np.ndarray:
    """(n, k) linear-interpolation weights of x on the knots (constant beyond the ends): Σ_k B_k(x) θ_k is the
    piecewise-linear table through (knots, θ). Two nonzero weights per row; memory n × k."""
    knots = np.asarray(knots, float)
    x = np.clip(np.asarray(x, float).ravel(), knots[0], knots[-1])
    j = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, knots.size - 2)
    w = (x - knots[j]) / (knots[j + 1] - knots[j])
    B = np.zeros((x.size, knots.size))
    rows = np.arange(x.size)
    B[rows, j] = 1.0 - w
    B[rows, j + 1] += w
    return B


class TermModel:
    """The terms of a device in its active coordinates.

    Parameters
    ----------
    compiled : CompiledDevice of a serial device.

    Attributes: ``terms``; ``names`` (column names, file order); ``values`` (the file's coefficients);
    ``units`` (one per column).
    """

    def __init__(self, compiled):
        from .rigid_body import joint_frames, tree_joint_numbers

        self.compiled = compiled
        self.device = compiled.device
        self.terms = tuple(getattr(self.device, "terms", ()) or ())
        self.numbers = tree_joint_numbers(self.device)
        frames = joint_frames(self.device)
        self.prismatic = {num for num, f in zip(self.numbers, frames) if f.prismatic}
        L, c = compiled.active_map
        self.L, self.c = np.asarray(L, float), np.asarray(c, float)
        self.names: tuple[str, ...] = tuple(n for t in self.terms for n in t.column_names)
        vals = []
        for t in self.terms:
            v = list(t.values) or [0.0] * len(t.column_names)
            vals += v
        self.values = np.asarray(vals, float)
        self.units = [u for t in self.terms for u in self._units(t)]

    def __len__(self) -> int:
        return len(self.names)

    def _units(self, t) -> list[str]:
        lin = t.joint in self.prismatic
        force, q = ("N", "m") if lin else ("N·m", "rad")
        if t.kind == "functions":
            return [f"{force} per unit of {f}" for f in t.functions]
        if t.kind == "polynomial":
            return [f"{force}/{q}" + (f"^{k}" if k > 1 else "") for k in range(1, t.degree + 1)]
        if t.kind == "table":
            return [force] * len(t.knots)
        if t.kind == "spring":
            return ["N/m"] if t.rest_length is not None else ["N/m", "N"]
        if t.kind == "offset":
            return [force]
        return []

    # -- evaluation -----------------------------------------------------------------------------------
    def _tree(self, q_active) -> np.ndarray:
        return np.asarray(q_active, float) @ self.L.T + self.c

    def _at_joint(self, t, x_tree) -> np.ndarray:
        """Active-joint torques (n, na) of a torque x (n,) applied at tree joint t.joint."""
        k = self.numbers.index(t.joint)
        return x_tree[:, None] * self.L[k][None, :]

    def _columns_of(self, t, qt) -> list[np.ndarray]:
        """The term's columns on tree positions qt (n, nq): a list of (n, na) active joint torques."""
        if t.kind == "spring":
            return self._spring(t, qt)
        own = qt[:, self.numbers.index(t.joint)]
        if t.kind == "functions":
            byn = {num: qt[:, k] for k, num in enumerate(self.numbers)}
            return [self._at_joint(t, evaluate_expression(f, own, byn)) for f in t.functions]
        if t.kind == "polynomial":
            return [self._at_joint(t, own ** k) for k in range(1, t.degree + 1)]
        if t.kind == "table":
            B = hat_basis(own, t.knots)
            return [self._at_joint(t, B[:, k]) for k in range(B.shape[1])]
        if t.kind == "offset":
            return [self._at_joint(t, np.ones_like(own))]
        return []

    def columns(self, q_active) -> np.ndarray:
        """Φ (n, n_active, n_columns): the active-joint torques of a unit value of every column [N·m or N per
        unit of the column], on active positions q_active (n, n_active) [rad or m]."""
        qt = self._tree(np.atleast_2d(q_active))
        n, na = qt.shape[0], self.L.shape[1]
        cols = [c for t in self.terms for c in self._columns_of(t, qt)]
        return np.stack(cols, axis=2) if cols else np.zeros((n, na, 0))

    def known(self, q_active) -> np.ndarray:
        """The known torques (n, n_active) [N·m or N] of the ``known`` terms, to subtract from measured ones."""
        qt = self._tree(np.atleast_2d(q_active))
        out = np.zeros((qt.shape[0], self.L.shape[1]))
        for t in self.terms:
            if t.kind != "known":
                continue
            own = qt[:, self.numbers.index(t.joint)]
            if t.function is not None:
                x = evaluate_expression(t.function, own, {num: qt[:, k] for k, num in enumerate(self.numbers)})
            else:
                x = np.interp(own, np.asarray(t.knots, float), np.asarray(t.torques, float))
            out += self._at_joint(t, x)
        return out

    def torque(self, q_active, values=None) -> np.ndarray:
        """Total term torque (n, n_active): Φ θ + known, θ = ``values`` (default the file's)."""
        th = self.values if values is None else np.asarray(values, float)
        return self.columns(q_active) @ th + self.known(q_active)

    @property
    def has_known(self) -> bool:
        return any(t.kind == "known" for t in self.terms)

    # -- springs ------------------------------------------------------------------------------------------
    def _point(self, link: int, p) -> tuple[int, np.ndarray]:
        """(Pinocchio joint id, point in that joint's frame) of a point given in link ``link``'s frame."""
        if link == 0:
            return 0, np.asarray(p, float)
        from .rigid_body import link_point_in_joint_frame

        return self.numbers.index(link) + 1, link_point_in_joint_frame(self.device, link, p)

    def _spring(self, t, qt) -> list[np.ndarray]:
        import pinocchio as pin

        model = self.compiled.pinocchio_model
        data = model.createData()
        (ja, pa), (jb, pb) = self._point(t.link_a, t.point_a), self._point(t.link_b, t.point_b)
        n = qt.shape[0]
        length = np.empty(n)
        dl = np.empty((n, qt.shape[1]))
        for s in range(n):
            pin.computeJointJacobians(model, data, qt[s])
            ends = []
            for jid, p in ((ja, pa), (jb, pb)):
                if jid == 0:
                    ends.append((p, np.zeros((3, model.nv))))
                    continue
                M = data.oMi[jid]
                pw = M.act(p)
                J = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                r = pw - M.translation
                ends.append((pw, J[:3] - np.cross(r, J[3:].T).T))     # v_p = v_o + ω × r
            d = ends[1][0] - ends[0][0]
            length[s] = np.linalg.norm(d)
            u = d / max(length[s], 1e-12)
            dl[s] = u @ (ends[1][1] - ends[0][1])
        dla = dl @ self.L              # ∂l/∂q_active
        if t.rest_length is not None:
            return [(length - t.rest_length)[:, None] * dla]
        return [length[:, None] * dla, -dla]

    # -- the twin -------------------------------------------------------------------------------------------
    def joint_tables(self, n_knots: int = 4001, margin: float = 0.5):
        """Per active joint a uniform table of the total term torque (file values) over its own coordinate, for
        the simulator: (lo (na,), step (na,), table (na, n_knots)) [rad or m, N·m or N]; None when the device has
        no terms. Raises DeviceError (a ValueError) naming a term whose torque depends on more than one joint or acts on another
        active joint than its own (the twin's tables are one-dimensional)."""
        if not self.terms:
            return None
        compiled = self.compiled
        na = self.L.shape[1]
        lo_hi = []
        active_numbers = [self.numbers[k] for k in compiled.active_joints]
        for num in active_numbers:
            lo_hi.append(joint_range(self.device.kinematics.joints[num - 1], margin))
        rng = np.random.default_rng(0)
        base = np.array([rng.uniform(a, b) for a, b in lo_hi])
        lo = np.array([a for a, _ in lo_hi])
        step = np.array([(b - a) / (n_knots - 1) for a, b in lo_hi])
        table = np.zeros((na, n_knots))
        for i in range(na):
            q = np.tile(base, (n_knots, 1))
            q[:, i] = lo[i] + step[i] * np.arange(n_knots)
            tau = self.torque(q)
            if not np.all(np.isfinite(tau)):
                from .base import DeviceError

                path = getattr(self.device, "path", None)
                raise DeviceError(f"the terms' torque on joint {active_numbers[i]} is not finite over "
                                  f"[{lo_hi[i][0]:.4g}, {lo_hi[i][1]:.4g}]", file=None if path is None else path.name,
                                  field="terms")
            table[i] = tau[:, i]
            # the torque must be this joint's alone, of this joint's coordinate alone
            other = np.delete(tau - tau[:1], i, axis=1)
            q2 = q.copy()
            q2[:, [k for k in range(na) if k != i]] = np.array([rng.uniform(a, b) for a, b in lo_hi])[
                [k for k in range(na) if k != i]]
            if np.max(np.abs(other), initial=0.0) > 1e-9 * (1 + np.max(np.abs(tau))) or \
                    not np.allclose(self.torque(q2)[:, i], tau[:, i], rtol=1e-9, atol=1e-12):
                from .base import DeviceError

                culprit = [t.name for t in self.terms if t.kind == "spring" or t.kind in ("functions", "known")]
                path = getattr(self.device, "path", None)
                raise DeviceError(f"the twin simulates terms whose torque on an active joint depends on that "
                                  f"joint's position alone; joint {active_numbers[i]} (terms "
                                  f"{', '.join(culprit) or '?'}) does not (identification takes them)",
                                  file=None if path is None else path.name, field="terms")
        return lo, step, table
