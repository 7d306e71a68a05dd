"""Couplings as other robot software writes them, read into G (q_motor = G q) and written as ``[[actuators]]``.

Formats (docs/device-file.md, "Coupling files"; facts from each project's documentation and configuration files):

* ``dvrk`` — JSON (``//`` and ``/* */`` comments allowed), a ``"coupling"`` object with up to four square matrices
  as lists of rows: ``ActuatorToJointPosition`` (G⁻¹), ``JointToActuatorPosition`` (G), ``ActuatorToJointEffort``
  (Gᵀ), ``JointToActuatorEffort`` (G⁻ᵀ); key spelling is free as to case and underscores
  (``actuator_to_joint_position``). The position pair must be inverse of each other, and effort ones
  power-consistent with them (relative tolerance 1e-3: the files print 4 decimals).
* ``libbarrett`` — libconfig text, ``j2mp = ((…), (…), …);`` the joint-to-motor position matrix (G) in rows;
  else ``m2jp`` (G⁻¹); ``j2mt`` (G⁻ᵀ) checked when present.
* ``icub`` — YARP XML, ``<param name="matrixM2J"> …row-major numbers… </param>`` = dq_joint/dq_motor with motor
  angles in joint units (G⁻¹ up to the gearbox), and ``<param name="Gearbox_M2J">`` per motor (absent: 1):
  G = diag(Gearbox_M2J) · matrixM2J⁻¹ (motor rotor angles). ``matrixJ2M`` is a control matrix, not read.
* ``plain`` — whitespace- or comma-separated rows of G itself (``#`` comments).

A matrix larger than the device's active joints is accepted when its extra rows and columns are decoupled from the
leading block (dVRK tools pad to 7×7 with ones on the diagonal): the leading block is taken.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

FORMATS = ("auto", "dvrk", "libbarrett", "icub", "plain")
MAX_COUPLING_BYTES = 1 << 20
"""Largest coupling file read [bytes] (checked before reading; real ones are a few KiB)."""
MAX_COUPLING_SIZE = 64
"""Largest coupling matrix [rows] (a robot's motors; dVRK pads to 7)."""
MAX_COUPLING_ENTRY = 1e6
"""Largest |entry| of a coupling matrix [rad/rad] (a reduction ratio; larger is a unit or typing error)."""
MAX_JSON_DEPTH = 64
"""Deepest nesting of a dVRK JSON file (its coupling sits 2–4 levels down)."""
CONSISTENCY_RTOL = 1e-3
"""Relative tolerance [-] of the inverse/transpose checks between matrices of one file (printed decimals)."""


class CouplingFileError(ValueError):
    """A coupling file that cannot be read or is inconsistent (the message names the file and the matrix)."""


def detect_format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".json":
        return "dvrk"
    if suffix == ".xml":
        return "icub"
    if suffix in (".conf", ".cfg"):
        return "libbarrett"
    return "plain"


def read_coupling(path, fmt: str = "auto") -> tuple[np.ndarray, str]:
    """(G, format) from a coupling file: G (n, n) motor-from-joint position matrix [rad/rad]."""
    path = Path(path)
    fmt = detect_format(path) if fmt == "auto" else fmt
    if fmt not in FORMATS[1:]:
        raise CouplingFileError(f"unknown coupling format {fmt!r}; expected one of {', '.join(FORMATS)}")
    try:
        size = path.stat().st_size
        if size > MAX_COUPLING_BYTES:
            raise CouplingFileError(f"{path.name}: {size} bytes, larger than the {MAX_COUPLING_BYTES} a coupling file "
                                    "may have")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CouplingFileError(f"{path}: cannot read: {exc}") from None
    reader = {"dvrk": _dvrk, "libbarrett": _libbarrett, "icub": _icub, "plain": _plain}[fmt]
    G = reader(text, path.name)
    if not np.all(np.isfinite(G)):
        raise CouplingFileError(f"{path.name}: the coupling has non-finite entries")
    return G, fmt


def _square(rows, where: str) -> np.ndarray:
    try:
        M = np.array(rows, dtype=float)
    except (ValueError, TypeError):
        raise CouplingFileError(f"{where}: not a matrix of numbers (ragged rows or text)") from None
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.size == 0:
        raise CouplingFileError(f"{where}: must be a square matrix (got shape {M.shape})")
    if M.shape[0] > MAX_COUPLING_SIZE:
        raise CouplingFileError(f"{where}: {M.shape[0]}×{M.shape[0]}, larger than {MAX_COUPLING_SIZE}×"
                                f"{MAX_COUPLING_SIZE}")
    if not np.all(np.isfinite(M)):
        raise CouplingFileError(f"{where}: entries must be finite numbers (got {M[~np.isfinite(M)][0]})")
    if np.abs(M).max() > MAX_COUPLING_ENTRY:
        raise CouplingFileError(f"{where}: an entry of magnitude {np.abs(M).max():.3g} is beyond "
                                f"±{MAX_COUPLING_ENTRY:g} [rad/rad]")
    return M


def _inverse(M: np.ndarray, where: str) -> np.ndarray:
    if np.linalg.cond(M) > 1e12:
        raise CouplingFileError(f"{where}: singular: the joint angles cannot be recovered from the motor angles")
    return np.linalg.inv(M)


def _check(A: np.ndarray, B: np.ndarray, what: str) -> None:
    if A.shape != B.shape or not np.allclose(A, B, rtol=CONSISTENCY_RTOL, atol=CONSISTENCY_RTOL * np.abs(B).max()):
        err = float(np.abs(A - B).max()) if A.shape == B.shape else float("nan")
        raise CouplingFileError(f"{what} (largest difference {err:.3g}): the file's matrices disagree")


# ---- dVRK ----------------------------------------------------------------------------------------------

def _strip_js_comments(text: str) -> str:
    out, i, n, in_str = [], 0, len(text), False
    while i < n:
        ch = text[i]
        if in_str:
            out.append(ch)
            if ch == "\\" and i + 1 < n:
                out.append(text[i + 1])
                i += 2
                continue
            if ch == '"':
                in_str = False
            i += 1
        elif ch == '"':
            in_str = True
            out.append(ch)
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
        else:
            out.append(ch)
            i += 1
    return "".join(out)


def _key(k: str) -> str:
    return k.replace("_", "").replace("-", "").lower()


def _find_coupling(doc):
    if isinstance(doc, dict):
        for k, v in doc.items():
            if _key(k) == "coupling" and isinstance(v, dict):
                return v
        for v in doc.values():
            found = _find_coupling(v)
            if found is not None:
                return found
    elif isinstance(doc, list):
        for v in doc:
            found = _find_coupling(v)
            if found is not None:
                return found
    return None


def _position_map(forward, inverse, name: str, forward_label: str, inverse_label: str, missing: str) -> np.ndarray:
    """G (joint → motor position) from a file that gives it, its inverse, or both (then checked: inverse · G = I)."""
    if forward is not None:
        if inverse is not None:
            _check(inverse @ forward, np.eye(len(forward)), f"{name}: {inverse_label} · {forward_label} is not I")
        return forward
    if inverse is not None:
        return _inverse(inverse, f"{name}: {inverse_label}")
    raise CouplingFileError(f"{name}: {missing}")


def _dvrk(text: str, name: str) -> np.ndarray:
    def no_constant(word):
        raise CouplingFileError(f"{name}: {word} is not a number a coupling can hold")

    try:
        doc = json.loads(_strip_js_comments(text), parse_constant=no_constant)
    except json.JSONDecodeError as exc:
        raise CouplingFileError(f"{name}: not JSON: {exc}") from None
    except RecursionError:
        raise CouplingFileError(f"{name}: not JSON: nested too deep") from None
    stack = [(doc, 1)]                      # iterative: the search below may then recurse safely
    while stack:
        node, depth = stack.pop()
        if depth > MAX_JSON_DEPTH:
            raise CouplingFileError(f"{name}: nested deeper than {MAX_JSON_DEPTH} levels")
        if isinstance(node, dict):
            stack.extend((v, depth + 1) for v in node.values())
        elif isinstance(node, list):
            stack.extend((v, depth + 1) for v in node)
    coup = _find_coupling(doc)
    if coup is None:
        raise CouplingFileError(f"{name}: no \"coupling\" object (dVRK: coupling.ActuatorToJointPosition …)")
    mats = {_key(k): _square(v, f"{name}: coupling.{k}") for k, v in coup.items() if isinstance(v, list)}
    G = _position_map(mats.get("jointtoactuatorposition"), mats.get("actuatortojointposition"), name,
                      "JointToActuatorPosition", "coupling.ActuatorToJointPosition",
                      "the coupling has neither ActuatorToJointPosition nor JointToActuatorPosition")
    if "actuatortojointeffort" in mats:
        _check(mats["actuatortojointeffort"], G.T, f"{name}: ActuatorToJointEffort is not the transpose of "
                                                   "JointToActuatorPosition (virtual work)")
    if "jointtoactuatoreffort" in mats:
        _check(mats["jointtoactuatoreffort"] @ G.T, np.eye(len(G)),
               f"{name}: JointToActuatorEffort is not the inverse transpose of JointToActuatorPosition")
    return G


# ---- libbarrett (libconfig) --------------------------------------------------------------------------------

def _libconfig_matrix(text: str, key: str, name: str) -> np.ndarray | None:
    m = re.search(rf"(?<![\w.]){key}\s*[=:]\s*\(", text)
    if not m:
        return None
    i, depth, start = m.end() - 1, 0, m.end() - 1
    while i < len(text):
        if text[i] == "(":
            depth += 1
        elif text[i] == ")":
            depth -= 1
            if depth == 0:
                break
        i += 1
    body = text[start:i + 1]
    rows = [[float(x) for x in re.findall(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", r)]
            for r in re.findall(r"\(([^()]*)\)", body)]
    return _square(rows, f"{name}: {key}")


def _libbarrett(text: str, name: str) -> np.ndarray:
    text = re.sub(r"(#|//)[^\n]*", "", re.sub(r"/\*.*?\*/", "", text, flags=re.S))
    j2mp = _libconfig_matrix(text, "j2mp", name)
    m2jp = _libconfig_matrix(text, "m2jp", name)
    G = _position_map(j2mp, m2jp, name, "j2mp", "m2jp", "no j2mp (joint-to-motor position) or m2jp matrix")
    j2mt = _libconfig_matrix(text, "j2mt", name)
    if j2mt is not None:
        _check(j2mt @ G.T, np.eye(len(G)), f"{name}: j2mt is not the inverse transpose of j2mp")
    return G


# ---- iCub (YARP XML) ---------------------------------------------------------------------------------------

def _icub(text: str, name: str) -> np.ndarray:
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(re.sub(r"<!DOCTYPE[^>]*>", "", text))
    except ET.ParseError as exc:
        raise CouplingFileError(f"{name}: not XML: {exc}") from None
    params = {p.get("name", "").strip(): (p.text or "") for p in root.iter("param")}
    if "matrixM2J" not in params:
        raise CouplingFileError(f"{name}: no <param name=\"matrixM2J\"> (the motor-to-joint coupling)")
    try:
        values = [float(x) for x in params["matrixM2J"].split()]
    except ValueError:
        raise CouplingFileError(f"{name}: matrixM2J must hold numbers only") from None
    k = int(round(len(values) ** 0.5))
    if k * k != len(values) or k == 0:
        raise CouplingFileError(f"{name}: matrixM2J has {len(values)} numbers, not a square matrix")
    M2J = np.array(values).reshape(k, k)
    gear = np.ones(k)
    if "Gearbox_M2J" in params:
        try:
            g = [float(x) for x in params["Gearbox_M2J"].split()]
        except ValueError:
            raise CouplingFileError(f"{name}: Gearbox_M2J must hold numbers only") from None
        if len(g) > k or any(x == 0 for x in g):
            raise CouplingFileError(f"{name}: Gearbox_M2J must give at most {k} nonzero ratios (got {g})")
        gear[:len(g)] = g
    return np.diag(gear) @ _inverse(M2J, f"{name}: matrixM2J")


# ---- plain ---------------------------------------------------------------------------------------------------

def _plain(text: str, name: str) -> np.ndarray:
    rows = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            try:
                rows.append([float(x) for x in re.split(r"[,\s]+", line) if x])
            except ValueError:
                raise CouplingFileError(f"{name}: not a matrix of numbers: {line!r}") from None
    return _square(rows, name)


# ---- to a device ---------------------------------------------------------------------------------------------

def fit_to_device(G: np.ndarray, n_active: int, where: str) -> np.ndarray:
    """The leading (n, n) block of G when G is larger and its extra motors/joints are decoupled from it."""
    if G.shape[0] == n_active:
        return G
    if G.shape[0] < n_active:
        raise CouplingFileError(f"{where}: a {G.shape[0]}×{G.shape[0]} coupling for a device with {n_active} "
                                "active joints")
    if np.any(G[:n_active, n_active:] != 0) or np.any(G[n_active:, :n_active] != 0):
        raise CouplingFileError(f"{where}: a {G.shape[0]}×{G.shape[0]} coupling for a device with {n_active} "
                                f"active joints, and its motors beyond {n_active} are coupled to the first joints")
    return G[:n_active, :n_active]


def assign_joints(G: np.ndarray) -> list[int]:
    """For each motor (row), the 0-based column it is written as driving (``joint``): a perfect matching over the
    nonzero entries that keeps the diagonal wherever it is nonzero (so the file reads as the usual one-motor-per-
    joint layout), the motor order unchanged."""
    from scipy.optimize import linear_sum_assignment

    nz = np.abs(G) > 0
    cost = np.where(nz, 1.0, 1e6)
    np.fill_diagonal(cost, np.where(np.diag(nz), 0.0, 1e6))
    rows, cols = linear_sum_assignment(cost)
    if np.any(~nz[rows, cols]):
        raise CouplingFileError("the coupling is structurally singular: no motor-to-joint assignment over its "
                                "nonzero entries")
    out = [0] * len(rows)
    for r, c in zip(rows, cols):
        out[int(r)] = int(c)
    return out


def actuator_entries(G: np.ndarray, joint_numbers, priors=None) -> list[dict]:
    """``[[actuators]]`` entries (dicts of device-file keys) reproducing G row by row: motor i keeps row i."""
    cols = assign_joints(G)
    out = []
    for i, j in enumerate(cols):
        N = float(G[i, j])
        coupling = {str(joint_numbers[k]): float(G[i, k] / N) for k in range(G.shape[1]) if k != j and G[i, k] != 0}
        bad = {k: v for k, v in coupling.items() if abs(v) > 1e3}
        if bad:
            raise CouplingFileError(f"motor {i + 1}: coupling coefficients {bad} exceed 1000 relative to its ratio "
                                    f"{N:g} (a device file allows |coupling| <= 1000)")
        entry = {"name": f"motor{i + 1}", "joint": int(joint_numbers[j]), "ratio": N, "coupling": coupling}
        if priors is not None and i < len(priors):
            entry.update(priors[i])
        out.append(entry)
    return out


_HEADER = re.compile(r"^\s*\[\[?\s*([A-Za-z_][\w\-]*)[\w.\- ]*\]\]?\s*(#.*)?$")
_ACTUATION = ("transmissions", "drives", "actuators")


def strip_actuation(text: str) -> str:
    """The device-file text without its ``[[transmissions]]``, ``[[drives]]`` and ``[[actuators]]`` sections (and
    their sub-tables), everything else (comments included) kept."""
    out, skipping = [], False
    for line in text.splitlines():
        header = _HEADER.match(line)
        if header:
            skipping = header.group(1) in _ACTUATION
        if not skipping:
            out.append(line)
    return "\n".join(out).rstrip("\n") + "\n"


def _toml_value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    return repr(float(v)) if isinstance(v, float) else str(v)


def device_text(source_text: str, source_dir: Path, out_dir: Path, entries: list[dict], origin: str) -> str:
    """The new device file: the source text without its actuation, relative URDF paths made absolute when the file
    moves, then the ``[[actuators]]`` entries."""
    text = strip_actuation(source_text)
    if source_dir.resolve() != out_dir.resolve():
        def absolute(m):
            p = Path(m.group(2))
            return m.group(1) + json.dumps(str(p if p.is_absolute() else (source_dir / p).resolve()))
        text = re.sub(r'^(\s*urdf\s*=\s*)"([^"]*)"', absolute, text, flags=re.M)
    lines = [text.rstrip("\n"), "", f"# [[actuators]] imported by `tendyn routing import` from {origin}:",
             "# q_motor = ratio * (q_joint + sum(coupling * q_k)); motor i = the i-th entry (the file's row i)."]
    for e in entries:
        lines.append("[[actuators]]")
        for k, v in e.items():
            if k == "coupling" and not v:
                continue
            lines.append(f"{k} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"
