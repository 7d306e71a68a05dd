"""Reading a device file and wording its errors: shared by every device loader (no loader imports another)."""

from __future__ import annotations

import datetime
import tomllib
from pathlib import Path
from typing import Any

from .schema import DeviceError


def typename(v: Any) -> str:
    """A value as a message names it: ``integer 3``, ``string 'x'``, ``a table`` …"""
    if isinstance(v, bool):
        return f"boolean {'true' if v else 'false'}"
    if isinstance(v, int):
        return f"integer {v}"
    if isinstance(v, float):
        return f"float {v!r}"
    if isinstance(v, str):
        return f"string {v!r}"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "an array"
    if isinstance(v, (datetime.date, datetime.time, datetime.datetime)):
        return f"date/time {v.isoformat()}"
    return type(v).__name__


def read_toml(p: Path) -> dict:
    """The parsed TOML of a device file; every problem raises one :class:`DeviceError` naming the file."""
    if not p.exists():
        raise DeviceError("file not found", file=str(p))
    if not p.is_file():
        raise DeviceError("not a regular file", file=str(p))
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise DeviceError(f"TOML syntax error: {exc}", file=p.name) from None
    except UnicodeDecodeError as exc:
        raise DeviceError(f"not valid UTF-8 text: {exc}", file=p.name) from None
    except RecursionError:          # `a = [[[[…` thousands deep
        raise DeviceError("TOML nested too deeply", file=p.name) from None
    except OSError as exc:
        raise DeviceError(f"cannot read file: {exc.strerror or exc}", file=str(p)) from None
