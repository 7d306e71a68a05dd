"""Bundled device files (the digital twins of the seed papers' devices).

>>> from tendyn.devices import bundled, available
>>> bundled("lexos").name
'lexos.toml'
"""

from __future__ import annotations

from pathlib import Path

from ..device.schema import DeviceError

__all__ = ["available", "bundled", "is_twin_of", "load"]

_HERE = Path(__file__).resolve().parent


def available() -> tuple[str, ...]:
    """Names of the bundled device files (file stems), sorted."""
    return tuple(sorted(p.stem for p in _HERE.glob("*.toml")))


def bundled(name: str) -> Path:
    """Path of a bundled device file.

    Parameters
    ----------
    name : str
        Device name, i.e. the file stem (``"lexos"``); a trailing ``.toml`` is accepted and case is ignored.

    Returns
    -------
    pathlib.Path
        Absolute path of the TOML file (load it with :func:`tendyn.device.load_device`).

    Raises
    ------
    DeviceError
        If no bundled device has that name; the message lists the available names.
    """
    if not isinstance(name, str):
        raise DeviceError(f"bundled device name must be a string (got {type(name).__name__})")
    stem = name.strip().lower()
    if stem.endswith(".toml"):
        stem = stem[: -len(".toml")]
    names = available()
    if stem not in names:
        raise DeviceError(f"no bundled device named {name!r}; available: {', '.join(names) or '(none)'}")
    return _HERE / f"{stem}.toml"


def load(name_or_path):
    """The device a command line or a caller names: a device file (a path ending in ``.toml`` or an existing
    file) or the name of a bundled twin (``"lexos"``). The one rule every command follows.

    Raises
    ------
    DeviceError
        If the file does not parse or no bundled device has that name.
    """
    from ..device import load_device

    path = Path(name_or_path)
    return load_device(path if path.suffix.lower() == ".toml" or path.exists() else bundled(str(name_or_path)))


def is_twin_of(device, name: str) -> bool:
    """Whether ``device`` (a Device or CompiledDevice) is the bundled twin ``name`` itself: its file has the same
    bytes as the bundled file. Only then may a result be compared with that paper's printed values (a user's
    device, or a twin edited by hand, is another device)."""
    dev = getattr(device, "device", device)
    path = getattr(dev, "path", None)
    try:
        return path is not None and Path(path).read_bytes() == bundled(name).read_bytes()
    except (OSError, DeviceError):
        return False
