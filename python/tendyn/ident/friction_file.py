"""FRICTION.json: the identified global friction of every transmission of a device (format
``tendyn.friction/1``, documented in ``docs/friction-file.md``).

Flat on purpose, so that a C/C++ compensator can load it with any JSON reader: the two arrays
``coulomb_motor`` and ``viscous_motor`` (one value per transmission, in transmission order) are all the
compensator needs; ``fits`` holds the statistics of each fit. Writes are atomic; the reader validates
everything and refuses a bad file with one line naming the field.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from tendyn.io.files import read_json

FORMAT = "tendyn.friction/1"


class FrictionFileError(ValueError):
    """A FRICTION.json is invalid; ``str(err)`` is ``FILE: FIELD: problem``.

    Attributes: ``file``, ``field`` (dotted path, 1-based transmission numbers in brackets), ``problem``.
    """

    def __init__(self, problem: str, *, file=None, field: str | None = None):
        self.file = None if file is None else str(file)
        self.field = field
        self.problem = problem
        super().__init__(": ".join([p for p in (self.file, field) if p] + [problem]))


def friction_document(device_name: str, fits) -> dict:
    """The FRICTION.json document for fits (:class:`tendyn.ident.friction.FrictionFit`, one per
    transmission, any order). Raises ValueError if a transmission is missing or twice."""
    from tendyn import __version__

    fits = sorted(fits, key=lambda f: f.transmission)
    nums = [f.transmission for f in fits]
    if nums != list(range(1, len(fits) + 1)):
        raise ValueError(f"fits must cover transmissions 1…{len(fits)} once each (got {nums})")
    doc = {"format": FORMAT, "device": device_name, "created_by": f"tendyn {__version__}",
           "n_transmissions": len(fits),
           "units": {"coulomb_motor": "N·m", "viscous_motor": "N·m·s/rad", "speeds_motor": "rad/s",
                     "load_coefficient": "-", "load_range_motor": "N·m"},
           "coulomb_motor": [f.coulomb_motor for f in fits],
           "viscous_motor": [f.viscous_motor for f in fits],
           "fits": [f.to_dict() for f in fits]}
    if any(getattr(f, "load_identified", False) for f in fits):
        doc["load_coefficient"] = [f.load_coefficient for f in fits]
    return doc


def write_friction(doc: dict, path) -> Path:
    """Validate ``doc`` and write it atomically (temporary file + rename)."""
    from tendyn.io import atomic_write_text

    validate_friction(doc, source=path)
    path = Path(path)
    atomic_write_text(path, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    return path


def _schema_bounds() -> dict:
    """The device schema's specs of the motor-side friction a FRICTION.json holds (one declared bound)."""
    from tendyn.device.schema import DRIVE_FIELDS

    return {spec.name: spec for spec in DRIVE_FIELDS if spec.name in ("coulomb_motor", "viscous_motor")}


_SCHEMA_BOUNDS = _schema_bounds()


def read_friction(path, device=None, physical: bool = False, force: bool | None = None) -> dict:
    """Read and validate a FRICTION.json; with ``device`` also check it is about that device (unless ``force``)
    and has exactly its transmissions; ``physical``: no negative friction (:func:`validate_friction`)."""
    path = Path(path)
    try:
        doc = read_json(path, parse_constant=lambda c: float(c))
    except OSError as e:
        raise FrictionFileError(f"cannot read: {e.strerror or e}", file=path) from None
    except json.JSONDecodeError as e:
        raise FrictionFileError(f"not JSON: {e.msg} (line {e.lineno})", file=path) from None
    validate_friction(doc, device=device, source=path, physical=physical, force=force)
    return doc


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def validate_friction(doc, device=None, source=None, physical: bool = False, force: bool | None = None) -> dict:
    """Check a friction document; raise :class:`FrictionFileError` naming the first bad field. ``physical``: also
    refuse a negative ``coulomb_motor`` or ``viscous_motor`` (a fit may come out negative; a model that uses it
    must not: a negative τ0 or ν would push the motion). ``force``: accept a file that names another device
    (its transmission count must still match); False (a command with ``--force``) or None (without) only
    changes the message."""
    def bad(field, problem):
        raise FrictionFileError(problem, file=source, field=field)

    if not isinstance(doc, dict):
        bad(None, "must be a JSON object")
    for key in ("format", "device", "n_transmissions", "coulomb_motor", "viscous_motor", "fits"):
        if key not in doc:
            bad(key, "missing")
    if doc["format"] != FORMAT:
        bad("format", f"must be {FORMAT!r} (got {doc['format']!r})")
    if not isinstance(doc["device"], str) or not doc["device"]:
        bad("device", "must be a non-empty string")
    n = doc["n_transmissions"]
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        bad("n_transmissions", f"must be an integer >= 1 (got {n!r})")
    if device is not None:
        if not force and not device.is_named(doc["device"]):
            hint = " (or --force to use it anyway)" if force is False else ""
            bad("device", f"the file is about {doc['device']!r}, not {device.name!r}{hint}")
        n_dev = device.n_transmissions or len(getattr(device, "drives", ()))   # capstan drives: one per drive
        if n != n_dev:
            bad("n_transmissions", f"{n} in the file, the device {device.name!r} has {n_dev}")
    for key in ("coulomb_motor", "viscous_motor"):
        arr = doc[key]
        if not isinstance(arr, list):
            bad(key, "must be a list with one value per transmission")
        if len(arr) != n:
            missing = f" (transmission {len(arr) + 1} missing)" if len(arr) < n else ""
            bad(key, f"{len(arr)} values for {n} transmissions{missing}")
        bound = _SCHEMA_BOUNDS[key]
        for k, x in enumerate(arr):
            if not _finite(x):
                bad(f"{key}[{k + 1}]", f"must be a finite number (got {x!r})")
            if abs(x) > bound.hi:
                bad(f"{key}[{k + 1}]", f"|{x!r}| is beyond {bound.hi:g} [{bound.unit}] (the device schema's bound on "
                                       f"{key})")
            if physical and x < 0:
                bad(f"{key}[{k + 1}]", f"must be >= 0 (got {x!r}): negative friction is not physical")
    load = doc.get("load_coefficient")   # optional: files of tendyn < 0.2 and fits without a load term
    if load is not None:
        if not isinstance(load, list) or len(load) != n:
            bad("load_coefficient", f"must be a list of {n} values (one per transmission)")
        for k, x in enumerate(load):
            if not _finite(x):
                bad(f"load_coefficient[{k + 1}]", f"must be a finite number (got {x!r})")
    fits = doc["fits"]
    if not isinstance(fits, list):
        bad("fits", "must be a list")
    seen = {}
    for k, f in enumerate(fits):
        where = f"fits[{k + 1}]"
        if not isinstance(f, dict):
            bad(where, "must be an object")
        t = f.get("transmission")
        if not isinstance(t, int) or isinstance(t, bool) or not 1 <= t <= n:
            bad(f"{where}.transmission", f"must be an integer in 1…{n} (got {t!r})")
        if t in seen:
            bad(f"{where}.transmission", f"transmission {t} appears twice")
        seen[t] = f
        for key in ("coulomb_motor", "viscous_motor", "coulomb_motor_std", "viscous_motor_std"):
            if key not in f:
                bad(f"{where}.{key}", "missing")
            if not _finite(f[key]):
                bad(f"{where}.{key}", f"must be a finite number (got {f[key]!r})")
        if load is not None and f.get("load_coefficient", 0.0) != load[t - 1]:
            bad(f"{where}.load_coefficient", f"{f.get('load_coefficient')!r} differs from "
                f"load_coefficient[{t}] = {load[t - 1]!r}")
        for key in ("coulomb_motor", "viscous_motor"):
            if f[key] != doc[key][t - 1]:
                bad(f"{where}.{key}", f"{f[key]!r} differs from {key}[{t}] = {doc[key][t - 1]!r}")
        if f.get("strategy") not in (None, "S1", "S2"):
            bad(f"{where}.strategy", f"must be 'S1', 'S2' or null (got {f.get('strategy')!r})")
        rb = f.get("residual_bound")
        if rb is not None and not _finite(rb):
            bad(f"{where}.residual_bound", f"must be a finite number or null (got {rb!r})")
    for t in range(1, n + 1):
        if t not in seen:
            bad("fits", f"transmission {t} missing")
    return doc
