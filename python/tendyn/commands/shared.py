"""What the command handlers share (issue 33: the helpers live with the commands, not in :mod:`tendyn.cli`, so
nothing below the command line imports it): the device argument, the ``--json`` output, the output folder and the
version. Light on purpose: the standard library and :mod:`tendyn.errors` at import time (a quick ``--help``)."""

from __future__ import annotations

import json
from pathlib import Path

from tendyn.errors import UsageError


def version() -> str:
    """The installed distribution's version, or ``"unknown"`` from a source tree."""
    from importlib.metadata import PackageNotFoundError, version as _dist_version

    try:
        return _dist_version("tendyn")
    except PackageNotFoundError:
        return "unknown"


def load(device_arg: str):
    """A device file path, or the name of a bundled twin (e.g. ``lexos``): :func:`tendyn.devices.load`."""
    from tendyn.devices import load as _load_device

    return _load_device(device_arg)


def print_json(doc, allow_nan: bool = True) -> None:
    """``doc`` as one JSON document on stdout (numpy arrays and scalars made plain, :func:`tendyn.io.to_jsonable`);
    ``allow_nan=False`` refuses NaN and Inf (ValueError) instead of writing JavaScript's tokens."""
    from tendyn.io import to_jsonable

    print(json.dumps(to_jsonable(doc), indent=2, allow_nan=allow_nan))


def check_out_folder(text: str, option: str = "out") -> Path:
    """An output folder (of ``--out`` or ``--report``) that exists as a folder or can be created (nothing is
    created here)."""
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise UsageError(f"{out} exists and is not a folder", option)
    from tendyn.io.files import creatable

    parent, problem = creatable(out / "_")      # the folder itself may be the nearest existing one
    if problem == "not a folder":
        raise UsageError(f"cannot create {out}: {parent} is not a folder", option)
    if problem:
        raise UsageError(f"cannot write into {parent} (permission denied)", option)
    return out


def calibrated(device, friction=None, params=None, stiffness=None, shares=None, force: bool | None = None,
               physical: bool = False):
    """The one place a command calibrates a device (:func:`tendyn.ident.calibrated.calibrate`): the device file
    (or a loaded device) with FRICTION.json, PARAMS.json, a capstan stiffness [N·m/rad] per drive and loss shares
    laid over it, each document read once; a document that cannot calibrate it is refused in one line (exit 2).
    ``force``: the command's ``--force`` (True takes another device's documents; False: refusals name the option;
    None: a command without it); ``physical``: FRICTION.json checked as a reader of its motor-side values
    (``decompose``, ``maps``)."""
    from tendyn.ident.calibrated import CalibrationError, calibrate

    dev = load(device) if isinstance(device, str) else device
    try:
        return calibrate(dev, friction, params, stiffness, shares, force=force, physical=physical)
    except CalibrationError as exc:
        raise UsageError(str(exc)) from None
