"""argparse converters for the subcommands: each checks its value and fails with a one-line message."""

from __future__ import annotations

import argparse
import math
from pathlib import Path


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, integer: bool = False,
           unit: str = ""):
    """A converter for a finite number (an integer if ``integer``) inside [lo, hi] (lo strict if ``lo_open``)."""
    def convert(text: str):
        try:
            v = int(text, 10) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {'an integer' if integer else 'a number'} (got {text!r})") from None
        if not integer and not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"must be finite (got {text!r})")
        if (lo is not None and (v <= lo if lo_open else v < lo)) or (hi is not None and v > hi):
            lo_txt = "" if lo is None else f"{lo:g} {'<' if lo_open else '≤'} "
            hi_txt = "" if hi is None else f" ≤ {hi:g}"
            raise argparse.ArgumentTypeError(f"must be {lo_txt}x{hi_txt}{f' [{unit}]' if unit else ''} (got {text})")
        return v
    return convert


def numbers(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, unit: str = ""):
    """A converter for a comma-separated list of numbers, each checked as by :func:`number`."""
    one = number(lo, hi, lo_open=lo_open, unit=unit)

    def convert(text: str):
        parts = [p.strip() for p in text.split(",")]
        if not parts or any(p == "" for p in parts):
            raise argparse.ArgumentTypeError(f"expected comma-separated numbers without empty entries (got {text!r})")
        return tuple(one(p) for p in parts)
    return convert


def existing_file(text: str) -> Path:
    """A path to an existing regular file."""
    p = Path(text)
    if not p.exists():
        raise argparse.ArgumentTypeError(f"{text}: file not found")
    if not p.is_file():
        raise argparse.ArgumentTypeError(f"{text}: not a regular file")
    return p


def existing_input(text: str) -> Path:
    """A RAW input of ``log import``: an existing regular file (CSV, .mat, .h5, .bag, .mcap, .db3) or a ROS 2 bag
    folder (a folder holding ``metadata.yaml``)."""
    p = Path(text)
    if not p.exists():
        raise argparse.ArgumentTypeError(f"{text}: file not found")
    if p.is_dir():
        if not (p / "metadata.yaml").is_file():
            raise argparse.ArgumentTypeError(f"{text}: a folder, but not a ROS 2 bag (no metadata.yaml in it)")
        return p
    if not p.is_file():
        raise argparse.ArgumentTypeError(f"{text}: not a regular file")
    return p


def report_dir(text: str) -> Path:
    """``--report DIR``: a folder that exists or can be created (nothing is created here)."""
    from tendyn.cli import _check_out_folder
    from tendyn.errors import UsageError

    try:
        return Path(_check_out_folder(text, "report"))
    except UsageError as exc:
        raise argparse.ArgumentTypeError(exc.problem) from None


def out_path(suffixes):
    """An output path with one of ``suffixes`` whose folder exists (nothing is written before the work)."""
    def convert(text: str) -> Path:
        p = Path(text)
        if p.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"must end in {' or '.join(suffixes)} (got {text!r})")
        if p.exists() and p.is_dir():
            raise argparse.ArgumentTypeError(f"{text} is a folder")
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.is_dir():
            raise argparse.ArgumentTypeError(f"folder {parent} does not exist")
        from tendyn.io.files import creatable

        if creatable(p)[1]:                     # /proc, a read-only mount, no permission
            raise argparse.ArgumentTypeError(f"cannot write into the folder {parent}")
        return p
    convert.__name__ = "path"
    return convert


def not_an_input(out: Path, inputs, option: str = "out") -> Path:
    """Refuse an output path that is one of the command's input files (it would overwrite, e.g., a lab's raw CSV)."""
    from tendyn.errors import UsageError

    out = Path(out)
    for p in inputs:
        same = out.resolve() == Path(p).resolve() or (out.exists() and Path(p).exists() and out.samefile(p))
        if same:                                # the same path, or another name of the same file (a link)
            raise UsageError(f"{out} is also an input file: it would be overwritten; write elsewhere", option)
    return out


def refuse_other_device(source, named, dev, force: bool = False) -> None:
    """Refuse a file about another device (``named`` is the device it names) unless ``--force``."""
    from tendyn.errors import UsageError

    if not force and not dev.is_named(named):
        raise UsageError(f"{source}: is about the device {named!r}, not {dev.name!r}; give the file of this device "
                         "(or --force to use it anyway)")
