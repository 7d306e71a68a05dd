"""argparse converters for the subcommands: each checks its value and fails with a one-line message."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Domain:
    """The declared domain of a numeric option: what its converter accepts and what the fuzz reads
    (tests/python/test_cli_domain_fuzz.py generates values just outside and inside it).

    lo, hi : bounds (None: unbounded); lo_open : lo excluded; integer : integers only; unit : SI unit;
    many : a comma-separated list; distinct : its entries must differ (a list)."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    integer: bool = False
    unit: str = ""
    many: bool = False
    distinct: bool = False

    def text(self) -> str:
        lo_txt = "" if self.lo is None else f"{self.lo:g} {'<' if self.lo_open else '≤'} "
        hi_txt = "" if self.hi is None else f" ≤ {self.hi:g}"
        return f"{lo_txt}x{hi_txt}{f' [{self.unit}]' if self.unit else ''}"


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, integer: bool = False,
           unit: str = ""):
    """A converter for a finite number (an integer if ``integer``) inside [lo, hi] (lo strict if ``lo_open``);
    its :class:`Domain` is ``convert.domain``."""
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
    convert.domain = Domain(lo, hi, lo_open, integer, unit)
    return convert


def numbers(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, unit: str = "",
            distinct: bool = False):
    """A converter for a comma-separated list of numbers, each checked as by :func:`number` (all different if
    ``distinct``: a stepped sine's frequencies); its :class:`Domain` is ``convert.domain``."""
    one = number(lo, hi, lo_open=lo_open, unit=unit)

    def convert(text: str):
        parts = [p.strip() for p in text.split(",")]
        if not parts or any(p == "" for p in parts):
            raise argparse.ArgumentTypeError(f"expected comma-separated numbers without empty entries (got {text!r})")
        values = tuple(one(p) for p in parts)
        if distinct and len(set(values)) != len(values):
            twice = sorted({v for v in values if values.count(v) > 1})
            raise argparse.ArgumentTypeError(f"each value once (got {', '.join(f'{v:g}' for v in twice)} twice)")
        return values
    convert.domain = Domain(lo, hi, lo_open, False, unit, many=True, distinct=distinct)
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
    from tendyn.commands.shared import check_out_folder
    from tendyn.errors import UsageError

    try:
        return Path(check_out_folder(text, "report"))
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


def choice(domain, what: str = "value"):
    """A converter for one name of ``domain`` (a mapping name → meaning, or a sequence of names)."""
    names = tuple(domain)

    def convert(text: str) -> str:
        if text not in names:
            raise argparse.ArgumentTypeError(f"must be one of {', '.join(names)} (got {text!r})")
        return text
    convert.__name__ = what
    return convert


def treatment_option(parser) -> None:
    """``--treatment NAME``: the data treatment of an identification, tendyn's or a peer's published script
    reproduced; the domain is :data:`tendyn.ident.treatment.PRESETS` (one table, the help lists it)."""
    from tendyn.ident.treatment import PRESETS

    parser.add_argument("--treatment", type=choice(PRESETS, "treatment"), default="tendyn", metavar="NAME",
                        help="data treatment: " + "; ".join(f"{k}: {v.source}" for k, v in PRESETS.items())
                             + " (default tendyn; given --cutoff-hz, --decimate, --velocity-threshold win)")


@dataclass(frozen=True)
class Boxes:
    """A parsed ``--bounds`` file: ``bounds`` {name: (lower, upper)} (None: no bound on that side), ``units``
    {name: unit} where the file states one, ``path`` the file."""

    path: Path
    bounds: dict
    units: dict


@dataclass(frozen=True)
class BoxesDomain:
    """The declared domain of a file of per-parameter boxes (``identify --bounds``): a TOML or JSON table
    ``NAME = [lower, upper]`` or ``NAME = {lower = .., upper = .., unit = ".."}`` (one side may be left out), with
    finite numbers, lower ≤ upper, at most ``max_entries`` names and ``max_bytes`` bytes. Names are a device's
    standard parameters (``M2``, ``FV1``, ``IAm6``, a term's name) or ``CX<j>``/``CY<j>``/``CZ<j>``, link j's centre
    of mass [m]; each in its parameter's unit (kg, kg·m, kg·m², N·m, N·m·s/rad, N/m, m), a stated ``unit`` must be
    it. Which names exist is checked against the DEVICE (:func:`tendyn.ident.consistent.check_bounds`)."""

    suffixes: tuple = (".toml", ".json")
    max_entries: int = 10000
    max_bytes: int = 1_000_000

    def text(self) -> str:
        return (f"a {' or '.join(self.suffixes)} table NAME = [lower, upper] or {{lower, upper, unit}}: finite, "
                f"lower ≤ upper, ≤ {self.max_entries} names")

    def parse(self, text: str) -> Boxes:
        """The boxes of the file at ``text``; argparse.ArgumentTypeError (one line) otherwise."""
        import json
        import re
        import tomllib

        bad = argparse.ArgumentTypeError
        p = Path(text)
        if p.suffix.lower() not in self.suffixes:
            raise bad(f"must end in {' or '.join(self.suffixes)} (got {text!r})")
        if not p.is_file():
            raise bad(f"{text}: file not found" if not p.exists() else f"{text}: not a regular file")
        if p.stat().st_size > self.max_bytes:
            raise bad(f"{text}: larger than {self.max_bytes} bytes")

        def no_constant(c):
            raise ValueError(f"{c} is not a finite number")
        try:
            raw = p.read_text(encoding="utf-8")
            doc = json.loads(raw, parse_constant=no_constant) if p.suffix.lower() == ".json" else tomllib.loads(raw)
        except (ValueError, UnicodeDecodeError, RecursionError) as exc:
            raise bad(f"{text}: not {p.suffix.lower()[1:].upper()} ({str(exc).splitlines()[0][:200]})") from None
        if not isinstance(doc, dict) or not doc:
            raise bad(f"{text}: must be a non-empty table of NAME = [lower, upper]")
        if len(doc) > self.max_entries:
            raise bad(f"{text}: {len(doc)} names, more than {self.max_entries}")

        def num(name, side, v):
            if v is None:
                return None
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise bad(f"{text}: {name} {side} must be a finite number (got {v!r:.40})")
            return float(v)
        bounds, units = {}, {}
        for name, v in doc.items():
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,63}", name):
                raise bad(f"{text}: {name[:40]!r} is not a parameter name")
            if isinstance(v, list):
                if len(v) != 2:
                    raise bad(f"{text}: {name} must be [lower, upper] (got {len(v)} values)")
                lo, hi = num(name, "lower", v[0]), num(name, "upper", v[1])
            elif isinstance(v, dict):
                extra = set(v) - {"lower", "upper", "unit"}
                if extra or not ({"lower", "upper"} & set(v)):
                    raise bad(f"{text}: {name} takes lower, upper (one at least) and unit (got "
                              f"{', '.join(sorted(map(str, v))) or 'nothing'})")
                lo, hi = num(name, "lower", v.get("lower")), num(name, "upper", v.get("upper"))
                if "unit" in v:
                    if not isinstance(v["unit"], str):
                        raise bad(f"{text}: {name} unit must be a string")
                    units[name] = v["unit"]
            else:
                raise bad(f"{text}: {name} must be [lower, upper] or {{lower, upper, unit}}")
            if lo is not None and hi is not None and lo > hi:
                raise bad(f"{text}: {name} lower {lo!r} > upper {hi!r}")
            bounds[name] = (lo, hi)
        return Boxes(p, bounds, units)

    def outside(self) -> list[tuple[str, str]]:
        """(suffix, content) of files just outside the domain (the fuzz writes and gives them)."""
        return [(".toml", "M1 = [2.0, 1.0]\n"), (".toml", "M1 = [0.0, inf]\n"), (".toml", "M1 = [0.0, nan]\n"),
                (".json", '{"M1": [0, Infinity]}'), (".json", '{"M1": [1, 2, 3]}'), (".toml", "M1 = [0, 1]\n[[[\n"),
                (".toml", ""), (".json", "[]"), (".toml", 'M1 = {lower = 0, above = 1}\n'), (".csv", "M1,0,1\n"),
                (".toml", 'M1 = ["0", 1]\n'), (".toml", "M1 = [true, 1]\n"),
                (".json", '{"M1": ' * 50_000 + "1" + "}" * 50_000)]

    def inside(self) -> list[tuple[str, str]]:
        """(suffix, content) of files the domain accepts."""
        return [(".toml", "M1 = [0.5, 2.0]\n"), (".toml", "M1 = [1.0, 1.0]\n"),
                (".toml", 'FV1 = {upper = 0.1, unit = "N·m·s/rad"}\nCX2 = [-0.1, 0.1]\n'),
                (".json", '{"M1": [0.5, 2.0], "IAm1": {"lower": 0.001}}')]


def boxes_file(text: str) -> Boxes:
    """``--bounds FILE``: per-parameter boxes, checked as by :class:`BoxesDomain`."""
    return boxes_file.domain.parse(text)


boxes_file.domain = BoxesDomain()


# ---- kinds an option applies to, and relations between options and the data ---------------------------------
# One table per command, read by the commands (check_applies, check_signals) and by the fuzz
# (tests/python/test_cli_domain_fuzz.py). Add a row here, not a check in a command.

_BENCH_PLANS = ("prbs", "multisine", "stepped-sine")
APPLIES_TO: dict[str, tuple[str, dict[str, tuple[str, ...]]]] = {
    "plan": ("experiment", {
        "transmission": ("constant-velocity",), "strategy": ("constant-velocity",), "speeds": ("constant-velocity",),
        "travel": ("constant-velocity",), "accel": ("constant-velocity",), "loads": ("constant-velocity",),
        "q0": ("constant-velocity",),
        "amplitude": _BENCH_PLANS, "duration": ("prbs", "multisine", "exciting"), "clock": ("prbs",),
        "bits": ("prbs",), "band": ("multisine",), "period": ("multisine",), "frequencies": ("stepped-sine",),
        "cycles": ("stepped-sine",), "settle": ("stepped-sine",), "seed": ("prbs", "exciting"),
        "name": _BENCH_PLANS, "unit": _BENCH_PLANS,
        "harmonics": ("exciting",), "base_hz": ("exciting",), "max_speed": ("exciting",),
        "iterations": ("exciting",), "periods": ("exciting",)}),
    "export": ("kind", {
        "friction": ("compensator", "transmission"), "shares": ("compensator", "transmission"),
        "k": ("compensator",), "velocity_band": ("compensator",), "velocity_cutoff": ("compensator",),
        "rate": ("compensator",), "lossless": ("mjcf",), "timestep": ("mjcf",), "four_bar": ("ros2-control",)}),
}
"""command → (the option that names the kind, {option: the kinds that use it}). An option given (not its default)
to a kind that ignores it is refused: ``plan exciting --transmission 1``, ``export mjcf --four-bar``."""


def applies(parser: argparse.ArgumentParser, command: str) -> None:
    """Bind :data:`APPLIES_TO`'s row of ``command`` to its parser (every option named must exist; the defaults
    are read from the parser so "given" means "not its default")."""
    dests = {a.dest: a.default for a in parser._actions}
    kind, table = APPLIES_TO[command]
    missing = [d for d in (kind, *table) if d not in dests]
    assert not missing, f"APPLIES_TO[{command!r}] names options {missing} the parser lacks"
    parser.set_defaults(_applies=(command, {d: dests[d] for d in table}))


def check_applies(args) -> None:
    """Refuse an option given to a kind that ignores it (before any work)."""
    from tendyn.errors import UsageError

    command, defaults = args._applies
    kind_dest, table = APPLIES_TO[command]
    kind = getattr(args, kind_dest)
    for dest, kinds in table.items():
        if kind not in kinds and getattr(args, dest, None) != defaults[dest]:
            raise UsageError(f"means nothing for `{command} {kind}` (it applies to {', '.join(kinds)})", dest)


OPTION_NEEDS: dict[str, dict[str, tuple[str, str]]] = {
    "identify": {"bounds": ("consistent", "the boxes constrain the physically consistent fit")},
    "zwidth": {"shares": ("friction", "the shares split identified friction")},
    "export": {"shares": ("friction", "the shares split identified friction")},
}
"""command → {option: (the option it needs, why)}: ``identify --bounds`` without ``--consistent`` is refused (the
plain least squares has no constraints to add boxes to). Checked by :func:`check_needs` before any work; the fuzz
(tests/python/test_cli_domain_fuzz.py) reads this table."""

OPTION_EXCLUDES: dict[str, dict[str, tuple[str, str]]] = {
    "zwidth": {"friction": ("compensator", "a compensator model file carries its own friction")},
}
"""command → {option: (the option it cannot go with, why)}: ``zwidth --friction F --compensator X`` is refused.
Checked by :func:`check_needs` before any work; the fuzz reads this table too."""


def check_needs(command: str, args) -> None:
    """Refuse an option of :data:`OPTION_NEEDS` given without the option it needs, or one of
    :data:`OPTION_EXCLUDES` given with the option it excludes (before any work)."""
    from tendyn.errors import UsageError

    def given(dest):
        value = getattr(args, dest, None)
        return value is not None and value is not False

    for dest, (other, why) in OPTION_NEEDS.get(command, {}).items():
        if given(dest) and not given(other):
            raise UsageError(f"needs --{other.replace('_', '-')} ({why})", dest)
    for dest, (other, why) in OPTION_EXCLUDES.get(command, {}).items():
        if given(dest) and given(other):
            raise UsageError(f"cannot go with --{other.replace('_', '-')} ({why}): give one of them", dest)


@dataclass(frozen=True)
class SignalDomain:
    """What logs a signal command can identify from: at least ``min_samples`` rows, one sample rate over the
    logs, an input and an output that vary (not constant, not all zero), ``nyquist`` options [Hz] whose largest
    value stays at or below rate/2, ``within_log`` options [samples] at most the shortest log's rows."""

    min_samples: int = 64
    same_rate: bool = True
    nyquist: tuple[str, ...] = ()
    within_log: tuple[str, ...] = ()


SIGNAL_DOMAINS = {
    "frf": SignalDomain(nyquist=("band",), within_log=("segment",)),
    "identify-bench": SignalDomain(),
}
"""command → the :class:`SignalDomain` its logs and options must satisfy (checked after reading, before work)."""

PLAN_RELATIONS = {
    "clock": "≤ --rate (one PRBS level per sample at most; its power, flat to 0.44 clock, then stays below the "
             "Nyquist frequency rate/2)",
    "band": "HI < --rate/2 (the Nyquist frequency)",
    "frequencies": "each < --rate/4 (a tone sampled at least 4 times a period)",
}
"""plan options related to ``--rate``, checked by :func:`check_plan_relations`."""


def check_plan_relations(args) -> None:
    """The bench plans' options against ``--rate`` (:data:`PLAN_RELATIONS`), before any work."""
    from tendyn.errors import UsageError

    rate = args.rate
    kind = args.experiment
    if kind == "prbs" and args.clock is not None and args.clock > rate:
        raise UsageError(f"{args.clock:g} Hz: must be {PLAN_RELATIONS['clock']} = {rate:g} Hz", "clock")
    if kind == "multisine" and args.band is not None and max(args.band) >= rate / 2:
        raise UsageError(f"{max(args.band):g} Hz: must be {PLAN_RELATIONS['band']} = {rate / 2:g} Hz", "band")
    if kind == "stepped-sine" and args.frequencies is not None and max(args.frequencies) >= rate / 4:
        raise UsageError(f"{max(args.frequencies):g} Hz: must be {PLAN_RELATIONS['frequencies']} = {rate / 4:g} Hz",
                         "frequencies")


MAX_AMPLITUDE = 1e4
"""Largest input amplitude a bench command takes (``plan --amplitude``, ``sweep --amplitudes``) [N, or the --unit
of a generic input] when nothing tighter is known: no DEVICE, or a bench file without the optional ``peak_force``
(a 1e308 N reference is refused, not written). A DEVICE that declares ``bench.peak_force`` bounds it by that
(:data:`DEVICE_LIMITS`)."""

DEVICE_LIMITS: dict[str, dict[str, str]] = {
    "plan": {"amplitude": "peak_force"},
    "sweep": {"amplitudes": "peak_force"},
}
"""command → {option: the bench field it must stay at or below}, in the field's unit (the option's [N] and the
field's [N] are both the command force at the rim). Checked by :func:`check_device_limits` once the DEVICE is
read; a device whose file leaves the field out (it is optional, :data:`tendyn.device.tendon_bench.BENCH_OPTIONAL`)
keeps only the option's fixed range, since nothing bounds it: the bundled McGill bench, whose paper (S1) gives no
actuator limit."""


def check_device_limits(command: str, args, dev) -> None:
    """The options of ``command`` against the device's limits (:data:`DEVICE_LIMITS`), before any work: the largest
    value of the option (a list's largest entry) must be ≤ the device's field when the file declares it."""
    from tendyn.errors import UsageError

    for opt, field in DEVICE_LIMITS[command].items():
        value = getattr(args, opt, None)
        limit = getattr(dev, field, None)
        if value is None or limit is None:
            continue
        top = max(value) if isinstance(value, (tuple, list)) else value
        if top > limit:
            raise UsageError(f"{float(top)!r} N: must be ≤ the device's peak force {float(limit)!r} N (bench.{field} "
                             f"of {dev.name})", opt)


def check_signals(command: str, args, logs, names, paths) -> None:
    """The logs and options of ``command`` against its :data:`SIGNAL_DOMAINS` row: ``logs`` read, ``names`` the
    (input, output) signals, ``paths`` the logs' files (for the message). Raises UsageError naming the option or
    the log, the value and the domain."""
    import numpy as np

    from tendyn.errors import UsageError

    dom = SIGNAL_DOMAINS[command]
    rates = [float(lg.meta["rate_hz"]) for lg in logs]
    for lg, path in zip(logs, paths):
        if lg.n_samples < dom.min_samples:
            raise UsageError(f"{Path(path).name}: {lg.n_samples} samples, fewer than the {dom.min_samples} a "
                             f"{command} needs", "logs")
        for name, opt in zip(names, ("input", "output")):
            x = np.asarray(lg[lg.resolve(name)], float)
            if not np.all(np.isfinite(x)):
                raise UsageError(f"{Path(path).name}: {name} is not finite everywhere", opt)
            if np.ptp(x) == 0:
                raise UsageError(f"{Path(path).name}: {name} is constant ({x[0]:g}): nothing to identify from "
                                 "(must vary)", opt)
    if dom.same_rate and len(set(rates)) > 1:
        raise UsageError(f"the logs have different sample rates ({', '.join(f'{r:g}' for r in rates)} Hz): must be "
                         "one rate (resample them first)", "logs")
    nyquist = min(rates) / 2
    for opt in dom.nyquist:
        v = getattr(args, opt, None)
        if v is not None and max(v) > nyquist:
            raise UsageError(f"{max(v):g} Hz: must be ≤ the logs' Nyquist frequency rate/2 = {nyquist:g} Hz", opt)
    shortest = min(lg.n_samples for lg in logs)
    for opt in dom.within_log:
        v = getattr(args, opt, None)
        if v is not None and v > shortest:
            raise UsageError(f"{v} samples: must be ≤ the shortest log's {shortest} samples", opt)
