"""The experiments a twin can run: their options, defaults and checks, in one table.

The command line builds ``tendyn simulate`` from this table, and Python callers get the same checks
through :func:`resolve`: every option is checked for type, finiteness and range, then against the
device (a 1-based index inside it, ``q0`` inside the joint limits, rates that divide each other) and
against the machine (a run whose arrays would not fit in memory is refused before it starts).
An option an experiment does not use is refused, never silently ignored.

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> opts = resolve(load_device(bundled("lexos")), "blocked-link", {"joint": 2})
>>> opts["joint"], opts["rate"], opts["log_rate"]
(2, 10000.0, 1000.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from tendyn.errors import UsageError, flag
from tendyn.protocols import DEFAULT_LOADS, DEFAULT_SPEEDS
from tendyn.sim.limits import (BENCH_RATE_HZ, CHAIN_RATE_HZ, MEMORY_SHARE, memory_available,  # noqa: F401 (API)
                               require_memory)

SEED_MAX = 2**64 - 1

PRBS_CLOCK_HZ = 50.0
"""Default PRBS clock of a tendon bench [Hz] (`simulate … prbs`, `pipeline s1`): a level lasts 20 ms; power flat
to ≈ 22 Hz. Chosen on the McGill twin, where it gives the dead-band 2 F_c (a 100 Hz clock gives 0.40 N there); on other benches it does not (docs/bench-identification.md)."""


@dataclass(frozen=True)
class Option:
    """One option of ``tendyn simulate``: its type, unit, range and help.

    kind: ``"float"``, ``"int"``, ``"seed"`` (0 … 2**64−1), ``"floats"`` (comma-separated list),
    ``"choice"``. Bounds ``lo``/``hi`` apply to every element of a list; ``lo_open`` makes lo strict.
    """

    name: str
    kind: str
    unit: str
    help: str
    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    choices: tuple = ()
    max_len: int = 0

    def range_text(self) -> str:
        if self.lo is None and self.hi is None:
            return ""
        lo = "" if self.lo is None else f"{_num(self.lo)} {'<' if self.lo_open else '≤'} "
        hi = "" if self.hi is None else f" ≤ {_num(self.hi)}"
        return f"{lo}x{hi}"


def _num(x: float) -> str:
    return f"{int(x)}" if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


OPTIONS: dict[str, Option] = {o.name: o for o in (
    Option("seed", "seed", "-", "noise seed (0 … 2**64−1)"),
    Option("rate", "float", "Hz", "integration rate (chains 1–20 kHz, default 10 kHz; tendon bench default 20 kHz)",
           lo=0.0, lo_open=True, hi=BENCH_RATE_HZ[1]),
    Option("control_rate", "float", "Hz", "controller and sensor rate (default 1 kHz for cable drives, "
           "5 kHz for capstan drives); divides --rate", lo=0.0, lo_open=True, hi=CHAIN_RATE_HZ[1]),
    Option("log_rate", "float", "Hz", "log sampling rate (default 1 kHz); divides the control rate "
           "(the step rate on a tendon bench)", lo=0.0, lo_open=True, hi=BENCH_RATE_HZ[1]),
    Option("q0", "floats", "rad", "initial active joint positions, comma-separated, inside the joint limits",
           max_len=64),
    Option("transmission", "int", "-", "1-based transmission (constant-velocity, stepped-sine, swept-sine)"),
    Option("joint", "int", "-", "1-based joint (blocked-link)"),
    Option("strategy", "choice", "-", "S0 identification strategy: S1 holds the other motors, S2 the other "
           "joints (default S2)", choices=("S1", "S2")),
    Option("speeds", "floats", "rad/s", "motor speeds, comma-separated (default 2,4,6,8,10: what "
           "identify-friction needs)", lo=0.0, lo_open=True, hi=1_000.0, max_len=50),
    Option("loads", "int", "-", "poses (gravity loads) of a constant-velocity test of a cable device, chosen "
           "from its limits and gravity model (default 2: the load-dependent friction needs two)", lo=1, hi=10),
    Option("duration", "float", "s", "length of an exciting trajectory or a swept sine (default 20 s; 120 s for "
           "the fast exciting design of elastic capstan drives)",
           lo=0.0, lo_open=True, hi=86_400.0),
    Option("torque", "float", "N·m or N", "input amplitude: motor torque [N·m] on chains (≤ the motor's peak "
           "torque), force command [N] on a tendon bench (default 0.1)", lo=0.0, lo_open=True, hi=1_000.0),
    Option("period", "float", "s", "triangle period of blocked-link (default 2 s)", lo=0.0, lo_open=True,
           hi=3_600.0),
    Option("cycles", "int", "-", "cycles of a blocked-link, stepped-sine or low-speed-loop test (default 3)",
           lo=1, hi=100_000),
    Option("freqs", "floats", "Hz", "test frequencies, comma-separated (stepped-sine; swept-sine sweeps from "
           "the lowest to the highest; default 1,2,5,10)", lo=0.0, lo_open=True, hi=100_000.0, max_len=1_000),
    Option("clock", "float", "Hz", "PRBS clock: a level lasts 1/clock (default 50 Hz: power flat to about 22 Hz); "
           "at most half of --log-rate", lo=0.0, lo_open=True, hi=BENCH_RATE_HZ[1]),
)}

DEFAULTS: dict[str, Any] = dict(seed=0, log_rate=1_000.0, transmission=1, joint=1, strategy="S2",
                                speeds=None, loads=DEFAULT_LOADS, duration=20.0, torque=0.1, period=2.0, cycles=3,
                                freqs=(1.0, 2.0, 5.0, 10.0), q0=None, clock=None)
"""Defaults shared by the experiments; rates that depend on the device come from :func:`_device_defaults`."""


@dataclass(frozen=True)
class Experiment:
    """An experiment of a kind of device: the options it uses (any other is refused)."""

    name: str
    kind: str
    uses: tuple[str, ...]
    help: str
    note: str = ""   # why an option it does not use is refused


_CHAIN, _BENCH = "serial", "tendon_bench_2n"
_TWIN_RATES = ("rate", "control_rate", "log_rate", "seed")
EXPERIMENTS: dict[tuple[str, str], Experiment] = {(e.kind, e.name): e for e in (
    Experiment("constant-velocity", _CHAIN, ("transmission", "strategy", "speeds", "loads", "q0") + _TWIN_RATES,
               "back-and-forth moves of one transmission at constant motor speeds (S0 §III-A)"),
    Experiment("exciting", _CHAIN, ("duration", "q0") + _TWIN_RATES,
               "triangular + sinusoidal joint trajectories (S2 §VI)"),
    Experiment("blocked-link", _CHAIN, ("joint", "torque", "period", "cycles", "q0") + _TWIN_RATES,
               "links blocked, triangular torque on one motor (S2 §V-C)"),
    Experiment("stepped-sine", _CHAIN, ("transmission", "freqs", "torque", "cycles", "q0", "rate", "seed"),
               "sinusoidal motor torque at each frequency, links free",
               note=" (it samples the sensors and logs at --rate)"),
    Experiment("swept-sine", _CHAIN, ("transmission", "freqs", "torque", "duration", "q0", "rate", "seed"),
               "linear chirp of motor torque, links free", note=" (it samples the sensors and logs at --rate)"),
    Experiment("stepped-sine", _BENCH, ("freqs", "torque", "cycles", "rate", "log_rate", "seed"),
               "sinusoidal force command at each frequency, from rest",
               note=" (a tendon bench has no controller and no joints)"),
    Experiment("swept-sine", _BENCH, ("freqs", "torque", "duration", "rate", "log_rate", "seed"),
               "linear chirp of force command", note=" (a tendon bench has no controller and no joints)"),
    Experiment("prbs", _BENCH, ("torque", "duration", "clock", "rate", "log_rate", "seed"),
               "maximum-length binary sequence ±torque of force command, from rest (S1 from logs: tendyn "
               "identify-bench)", note=" (a tendon bench has no controller and no joints)"),
    Experiment("low-speed-loop", _BENCH, ("torque", "cycles", "rate", "log_rate", "seed"),
               "0.2 Hz sine: dead-band and friction loop (S1 Fig. 10b)",
               note=" (a tendon bench has no controller and no joints)"),
)}
N_PLUS_ONE_EXPERIMENTS = ("constant-velocity", "exciting")
"""The chain experiments an N+1 device runs (joint-space PID); blocked-link, stepped-sine and swept-sine drive one
motor in torque mode, which the square twin's per-motor options do not express for n + 1 motors yet."""
EXPERIMENT_NAMES = tuple(dict.fromkeys(e.name for e in EXPERIMENTS.values()))


def experiments_of(device) -> tuple[str, ...]:
    """Names of the experiments ``device`` can run (declared by its kind, :class:`tendyn.device.Device`)."""
    return device.experiments


# ---- checks of single values ------------------------------------------------------------------------

def parse(name: str, text: str) -> Any:
    """Parse the command-line text of option ``name`` and check it (raises :class:`UsageError`)."""
    opt = OPTIONS[name]
    text = text.strip()
    try:
        if opt.kind in ("int", "seed"):
            value: Any = int(text, 10)
        elif opt.kind == "float":
            value = float(text)
        elif opt.kind == "floats":
            parts = [p.strip() for p in text.split(",")]
            if any(p == "" for p in parts):
                raise UsageError(f"expected comma-separated numbers without empty entries (got {text!r})", name)
            value = tuple(float(p) for p in parts)
        else:
            value = text
    except ValueError as exc:
        if isinstance(exc, UsageError):
            raise
        what = {"int": "an integer", "seed": "a non-negative integer", "float": "a number",
                "floats": "comma-separated numbers"}[opt.kind]
        raise UsageError(f"must be {what}{_unit(opt)} (got {text!r})", name) from None
    return check(name, value)


def _unit(opt: Option) -> str:
    return f" [{opt.unit}]" if opt.unit not in ("-", "") else ""


def check(name: str, value: Any) -> Any:
    """Check one option value of the Python API or the command line; returns it normalised."""
    opt = OPTIONS[name]
    if opt.kind == "choice":
        if value not in opt.choices:
            raise UsageError(f"must be one of {', '.join(opt.choices)} (got {value!r})", name)
        return value
    if opt.kind == "floats":
        if isinstance(value, (str, bytes)) or not np.iterable(value):
            raise UsageError(f"must be a list of numbers (got {type(value).__name__})", name)
        items = list(value)
        if not items:
            raise UsageError("must hold at least one number", name)
        if opt.max_len and len(items) > opt.max_len:
            raise UsageError(f"at most {opt.max_len} values (got {len(items)})", name)
        return tuple(_check_number(opt, v, name) for v in items)
    return _check_number(opt, value, name)


def _check_number(opt: Option, v: Any, name: str):
    integer = opt.kind in ("int", "seed")
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise UsageError(f"must be {'an integer' if integer else 'a number'} (got {type(v).__name__} {v!r})", name)
    if integer:
        if isinstance(v, (float, np.floating)) and not float(v).is_integer():
            raise UsageError(f"must be an integer (got {v!r})", name)
        v = int(v)
        if opt.kind == "seed" and not 0 <= v <= SEED_MAX:
            raise UsageError(f"must be a non-negative integer that fits in 64 bits, 0 … 2**64−1 (got {v})", name)
    else:
        v = float(v)
        if not math.isfinite(v):
            raise UsageError(f"must be finite (got {v!r})", name)
    low_bad = opt.lo is not None and (v <= opt.lo if opt.lo_open else v < opt.lo)
    if low_bad or (opt.hi is not None and v > opt.hi):
        raise UsageError(f"must be {opt.range_text()}{_unit(opt)} (got {_num(v) if integer else repr(v)})", name)
    return v


# ---- checks against the device -----------------------------------------------------------------------

def _active_count(device) -> int:
    return len(device.transmissions) or len(device.drives)


def _motors(device):
    return [t.motor for t in device.transmissions] or [d.motor for d in device.drives]


def _device_defaults(device, exp: Experiment) -> dict[str, Any]:
    if exp.kind == _BENCH:
        return {"rate": 20_000.0}
    from tendyn.sim.model import default_control_hz

    out = {"rate": 10_000.0, "control_rate": default_control_hz(device)}
    if exp.name == "exciting":      # 120 s with the fast design of elastic capstan drives, else 20 s
        from tendyn.sim.experiments import default_duration

        out["duration"] = default_duration(device)
    return out


def _divides(fast: float, slow: float) -> bool:
    k = fast / slow
    return k >= 1 - 1e-12 and abs(k - round(k)) <= 1e-9 * k


def resolve(device, experiment: str, given: dict[str, Any]) -> dict[str, Any]:
    """The full option set of one run of ``experiment`` on ``device``, every value checked.

    Parameters
    ----------
    device : a loaded device (chain, tree or tendon bench)
    experiment : one of :func:`experiments_of`
    given : options set by the caller (None = not given); any option the experiment does not use is an
        error, as is a value out of range or inconsistent with the device or the other options.

    Returns
    -------
    dict
        Option name → value, defaults filled in, for :func:`run`.

    Raises
    ------
    UsageError
        Naming the option (``--joint: must be 1…4 (got 0)``).
    """
    kind = device.kind
    if kind != _BENCH and not (getattr(device, "transmissions", ()) or getattr(device, "drives", ())):
        raise UsageError(f"{device.name} has neither cable transmissions nor capstan drives (geared actuators only): "
                         "the simulator has no twin of it", "device")
    exp = EXPERIMENTS.get((kind, experiment))
    if exp is None:
        names = ", ".join(experiments_of(device))
        what = "a tendon bench" if kind == _BENCH else "a chain"
        raise UsageError(f"{experiment!r} is not an experiment of {device.name} ({what}); its experiments: "
                         f"{names}", "experiment")
    if getattr(device, "n_plus_one", False) and experiment not in N_PLUS_ONE_EXPERIMENTS:
        raise UsageError(f"{experiment!r} does not take an N+1 device ({device.name}: n + 1 rigid tendons); its "
                         f"experiments: {', '.join(N_PLUS_ONE_EXPERIMENTS)} (docs/cli.md)", "experiment")
    for name, value in given.items():
        if name not in OPTIONS:
            raise UsageError(f"unknown option; known: {', '.join(flag(k) for k in OPTIONS)}", name)
        if value is not None and name not in exp.uses:
            used = ", ".join(flag(k) for k in exp.uses)
            raise UsageError(f"not an option of {experiment} on {device.name}{exp.note}; its options: {used}", name)
    opts = {k: DEFAULTS.get(k) for k in exp.uses}
    opts.update({k: v for k, v in _device_defaults(device, exp).items() if k in exp.uses})
    opts.update({k: v for k, v in given.items() if v is not None})
    opts = {k: (None if v is None else check(k, v)) for k, v in opts.items()}
    (_check_bench if kind == _BENCH else _check_chain)(device, exp, opts)
    _check_memory(device, exp, opts)
    return opts


def _check_chain(device, exp: Experiment, o: dict) -> None:
    lo, hi = CHAIN_RATE_HZ
    if not lo <= o["rate"] <= hi:
        raise UsageError(f"must be within {_num(lo)}–{_num(hi)} Hz on a chain (got {o['rate']:g})", "rate")
    if "control_rate" in o:
        if not _divides(o["rate"], o["control_rate"]):
            raise UsageError(f"must divide --rate ({o['rate']:g} Hz) a whole number of times "
                             f"(got {o['control_rate']:g})", "control_rate")
        if not _divides(o["control_rate"], o["log_rate"]):
            raise UsageError(f"must divide the control rate ({o['control_rate']:g} Hz) a whole number of "
                             f"times (got {o['log_rate']:g})", "log_rate")
    na = _active_count(device)
    for name in ("transmission", "joint"):
        if name in o and not 1 <= o[name] <= na:
            raise UsageError(f"must be 1…{na} (got {o[name]})", name)
    if o.get("q0") is not None:
        q0 = np.asarray(o["q0"], float)
        if q0.size != na:
            raise UsageError(f"needs one value per active joint of {device.name}: {na} values (got {q0.size})", "q0")
        from tendyn.sim.experiments import _active_limits

        lower, upper = _active_limits(device)
        for i, (q, a, b) in enumerate(zip(q0, lower, upper)):
            if a is not None and b is not None and not a <= q <= b:
                raise UsageError(f"joint {i + 1} = {q:g} rad is outside its limits [{a:g}, {b:g}] rad", "q0")
        if exp.name == "exciting":
            from tendyn.sim.experiments import default_design

            design = default_design(device)
            if design != "classic":     # it centres its motion in the joint limits: a start given would be ignored
                raise UsageError(f"the {design} exciting design of {device.name} centres its motion in the joint "
                                 "limits and starts there; --q0 sets the start of the classic design only", "q0")
    if "torque" in o:
        k = o.get("transmission", o.get("joint")) - 1
        peak = _motors(device)[k].peak_torque
        if o["torque"] > peak:
            raise UsageError(f"must be ≤ the peak torque of motor {k + 1}, {peak:g} N·m (got {o['torque']:g})",
                             "torque")
    _check_signal(o, o["rate"])


def _check_bench(device, exp: Experiment, o: dict) -> None:
    lo, hi = BENCH_RATE_HZ
    if not lo <= o["rate"] <= hi:
        raise UsageError(f"must be within {_num(lo)}–{_num(hi)} Hz on a tendon bench (got {o['rate']:g})", "rate")
    if not _divides(o["rate"], o["log_rate"]):
        raise UsageError(f"must divide --rate ({o['rate']:g} Hz) a whole number of times (got {o['log_rate']:g})",
                         "log_rate")
    _check_signal(o, o["rate"])
    if "clock" in o:
        if o["clock"] is None:
            o["clock"] = PRBS_CLOCK_HZ
        if o["clock"] > o["log_rate"] / 2:
            raise UsageError(f"must be at most half of --log-rate, {o['log_rate'] / 2:g} Hz (got {o['clock']:g})",
                             "clock")
        if o["duration"] * o["clock"] < 2:
            raise UsageError(f"must hold at least two PRBS levels, {2 / o['clock']:g} s at --clock "
                             f"{o['clock']:g} Hz (got {o['duration']:g})", "duration")


def _check_signal(o: dict, rate: float) -> None:
    """Frequencies below a quarter of the rate, periods and durations of several samples."""
    if "freqs" in o:
        bad = [f for f in o["freqs"] if f >= rate / 4]
        if bad:
            raise UsageError(f"must be below a quarter of --rate, {rate / 4:g} Hz (got {bad[0]:g})", "freqs")
    if o.get("duration") is not None and "freqs" in o and len(set(o["freqs"])) < 2:
        raise UsageError("a swept sine needs two different frequencies, its start and end (got "
                         f"{','.join(f'{f:g}' for f in o['freqs'])})", "freqs")
    if "period" in o and o["period"] * rate < 10:
        raise UsageError(f"must last at least 10 steps of --rate, {10 / rate:g} s (got {o['period']:g})", "period")
    log_rate = o.get("log_rate", rate)
    if o.get("duration") is not None and o["duration"] * log_rate < 2:
        raise UsageError(f"must hold at least two log samples, {2 / log_rate:g} s (got {o['duration']:g})",
                         "duration")


# ---- memory -------------------------------------------------------------------------------------------

def run_length_s(device, experiment: str, o: dict) -> list[float]:
    """Simulated seconds of each run of the experiment (one per frequency for a stepped sine)."""
    if experiment == "constant-velocity":
        from tendyn.protocols import constant_velocity_duration, duration_s

        test = planned_test(device, o)
        if test is None:
            return [constant_velocity_duration(o["speeds"] or DEFAULT_SPEEDS)]
        return [duration_s(_motor_from_joint(device), test)]
    if experiment in ("stepped-sine",):
        return [o["cycles"] / f for f in o["freqs"]]
    if experiment == "blocked-link":
        return [o["cycles"] * o["period"]]
    if experiment == "prbs":
        return [o["duration"]]
    if experiment == "low-speed-loop":
        from tendyn.sim.tendon_bench import LOW_SPEED_FREQ_HZ

        return [o["cycles"] / LOW_SPEED_FREQ_HZ]
    return [o["duration"] + (1.0 if device.kind == _BENCH else 0.0)]   # bench chirp: 1 s tail


def memory_needed(device, experiment: str, o: dict) -> float:
    """Peak memory [bytes] of the run's arrays: the per-step inputs and outputs of the longest run, plus
    every log (runs are kept until written), at float64."""
    lengths = run_length_s(device, experiment, o)
    rate = o["rate"]
    log_rate = o.get("log_rate", rate)
    if device.kind == _BENCH:
        per_step, per_row = 10, 4 * 2
    else:
        na = _active_count(device)
        per_step, per_row = 4 * na + 3, (12 * na + 2) * 2   # refs, feedforward, torques; log + true states
    return 8.0 * (max(lengths) * rate * per_step + sum(lengths) * log_rate * per_row)


def _check_memory(device, exp: Experiment, o: dict) -> None:
    require_memory(memory_needed(device, exp.name, o), "shorten it (fewer cycles or speeds, a shorter duration) "
                   "or lower --rate / --log-rate")


def planned_test(device, o: dict):
    """The constant-velocity test of a cable device planned by :func:`tendyn.protocols.plan_test` from the
    options (the same rule ``tendyn plan`` and ``identify-friction`` use) for cable transmissions and capstan
    drives (strokes and poses inside every tree joint's limits), or None for an N+1 routing."""
    if not (getattr(device, "transmissions", None) or getattr(device, "drives", None)) or \
            getattr(device, "n_plus_one", False):
        return None   # N+1: constant_velocity's own stroke inside the joint's limits (no S0 statics to plan with)
    from tendyn.protocols import plan_test

    return plan_test(device, o["transmission"], o["strategy"], o["speeds"], q0=o.get("q0"), loads=o["loads"],
                     strict=False)


def _motor_from_joint(device) -> np.ndarray:
    """G = R_m⁻¹ K of a cable device, diag(N) of capstan drives (motor from active joint positions)."""
    from tendyn.protocols import motor_from_joint

    return motor_from_joint(device)


# ---- running -----------------------------------------------------------------------------------------

def run(device, experiment: str, o: dict, progress: Callable[[int, int], None] | None = None) -> list:
    """Run a resolved experiment (see :func:`resolve`): a list of :class:`tendyn.sim.experiments.SimRun`."""
    if device.kind == _BENCH:
        from tendyn.sim import tendon_bench as tb
        from tendyn.sim.experiments import SimRun

        return [SimRun(log, truth) for log, truth in tb.bench_experiment(
            device, experiment, rate_hz=o["rate"], log_rate_hz=o["log_rate"], seed=o["seed"],
            amplitude_N=o["torque"], omega=None if o.get("freqs") is None else 2 * math.pi * np.asarray(o["freqs"]),
            cycles=o.get("cycles"),
            duration_s=o.get("duration"), clock_hz=o.get("clock"), progress=progress)]
    from tendyn.sim import experiments as ex

    q0 = None if o.get("q0") is None else np.asarray(o["q0"], float)
    common = dict(rate_hz=o["rate"], seed=o["seed"], progress=progress)
    twin = dict(control_hz=o.get("control_rate"), log_rate_hz=o.get("log_rate"), **common)
    if experiment == "constant-velocity":
        test = planned_test(device, o)
        if test is not None:
            return [ex.constant_velocity(device, test=test, **twin)]
        return [ex.constant_velocity(device, o["transmission"], o["speeds"] or DEFAULT_SPEEDS,
                                     strategy=o["strategy"], q0=q0, **twin)]
    if experiment == "exciting":
        return [ex.exciting_trajectory(device, duration=o["duration"], q0=q0, **twin)]
    if experiment == "blocked-link":
        return [ex.blocked_link(device, o["joint"], o["torque"], period=o["period"], cycles=o["cycles"], q0=q0,
                                **twin)]
    if experiment == "swept-sine":
        return [ex.swept_sine(device, o["transmission"], o["torque"], f0_hz=min(o["freqs"]),
                              f1_hz=max(o["freqs"]), duration=o["duration"], q0=q0, **common)]
    return ex.stepped_sine(device, o["transmission"], omega=2 * math.pi * np.asarray(o["freqs"]),
                           amplitude=o["torque"], cycles=o["cycles"], q0=q0, control_hz=o["rate"], **common)
