"""`tendyn plan prbs | multisine | stepped-sine`: identification references for a real bench, as reference logs
(issue 21). The `plan` subparser belongs to :mod:`tendyn.commands.s0`; it adds these kinds with
:func:`add_arguments` and hands them to :func:`run`. The signals are :mod:`tendyn.sim.excitation`'s, the ones
the S1 pipeline feeds the twin.

::

    tendyn plan prbs [DEVICE] --amplitude A --duration S [--clock HZ] [--rate HZ] --out REF.csv
    tendyn plan multisine [DEVICE] --amplitude A --duration S --band LO,HI [--period S] --out REF.csv
    tendyn plan stepped-sine [DEVICE] --amplitude A --frequencies F,… [--cycles N] [--settle S] --out REF.csv

The reference column is ``force_cmd`` [N] for a tendon bench DEVICE; without a DEVICE it is the generic
``input_1``, named by ``--name`` and ``--unit`` (docs/logs.md). A stepped sine writes one log per frequency
(``REF_01.csv``, …).
"""

from __future__ import annotations

import argparse

import numpy as np

from tendyn.commands import args as conv
from tendyn.errors import UsageError

KINDS = ("prbs", "multisine", "stepped-sine")
MAX_AMPLITUDE = conv.MAX_AMPLITUDE


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of the bench plans, on the `plan` parser."""
    g = p.add_argument_group("prbs, multisine, stepped-sine (a bench's identification references)")
    g.add_argument("--amplitude", type=conv.number(0.0, MAX_AMPLITUDE, lo_open=True, unit="N or --unit"), default=None,
                   help="level ±A of the PRBS, peak of the multisine, amplitude of the sines [N, or --unit]; "
                        "≤ the DEVICE's bench.peak_force when its file declares one, else ≤ 1e4 (no limit known: "
                        "the field is optional, and the McGill bench's paper gives none)")
    g.add_argument("--duration", type=conv.number(0.0, 1e5, lo_open=True, unit="s"), default=None,
                   help="length of the PRBS or multisine [s]")
    g.add_argument("--clock", type=conv.number(0.0, None, lo_open=True, unit="Hz"), default=None,
                   help="PRBS clock [Hz] (default: --rate; power flat to ≈ 0.44 clock)")
    g.add_argument("--bits", type=conv.number(2, 24, integer=True), default=10, help="PRBS register length (default 10)")
    g.add_argument("--band", type=conv.numbers(0.0, None, unit="Hz"), default=None, metavar="LO,HI",
                   help="multisine band [Hz]")
    g.add_argument("--period", type=conv.number(0.0, 1e4, lo_open=True, unit="s"), default=2.0,
                   help="multisine period [s] (lines every 1/period Hz; default 2)")
    g.add_argument("--frequencies", type=conv.numbers(0.0, None, lo_open=True, unit="Hz", distinct=True), default=None,
                   metavar="F,…", help="stepped-sine frequencies [Hz]")
    g.add_argument("--cycles", type=conv.number(1, 100000, integer=True), default=10,
                   help="measured cycles per stepped sine (default 10)")
    g.add_argument("--settle", type=conv.number(0.0, 1e4, unit="s"), default=1.0,
                   help="minimum settling time per stepped sine [s] (default 1)")
    g.add_argument("--seed", type=conv.number(0, 2**31 - 1, integer=True), default=0,
                   help="PRBS start state (default 0)")
    g.add_argument("--name", default=None, help="name of the generic input_1 (no DEVICE), e.g. voltage")
    g.add_argument("--unit", default=None, help="unit of the generic input_1 (no DEVICE), e.g. V")


def _need(args, *names):
    for n in names:
        if getattr(args, n) is None:
            raise UsageError(f"required for `plan {args.experiment}`", n)


def references(args) -> list[np.ndarray]:
    """The reference sequences (one per log) the arguments ask for; UsageError on a bad combination."""
    from tendyn.sim import excitation

    _need(args, "amplitude")
    try:
        if args.experiment == "prbs":
            _need(args, "duration")
            return [excitation.prbs(args.amplitude, args.duration, args.rate, clock_hz=args.clock, nbits=args.bits,
                                    seed=args.seed)]
        if args.experiment == "multisine":
            _need(args, "duration", "band")
            if len(args.band) != 2:
                raise UsageError(f"expected LO,HI [Hz] (got {len(args.band)} values)", "band")
            return [excitation.multisine(args.amplitude, args.duration, args.rate, band_hz=args.band,
                                         period_s=args.period)]
        _need(args, "frequencies")
        return excitation.stepped_sines(args.amplitude, args.frequencies, args.rate, cycles=args.cycles,
                                        settle_s=args.settle)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def run(args, load_device) -> int:
    """Write the reference logs; ``load_device`` reads the optional DEVICE (tendyn.commands.s0)."""
    from tendyn.io import make_log, write_log
    from tendyn.io.logs import LogError

    if args.device is not None:
        dev = load_device(args.device)
        if dev.kind != "tendon_bench_2n":
            raise UsageError(f"{dev.name} is a {dev.kind} device: give a tendon bench, or no DEVICE and --name/--unit "
                             "for a generic input", "device")
        conv.check_device_limits("plan", args, dev)
        column, signals, device = "force_cmd", None, dev.name
    else:
        _need(args, "name", "unit")
        column, signals, device = "input_1", {"input_1": {"name": args.name, "unit": args.unit}}, "bench"
    refs = references(args)
    keys = {"prbs": ("amplitude", "duration", "clock", "bits", "seed"), "multisine": ("amplitude", "duration", "band",
            "period"), "stepped-sine": ("amplitude", "cycles", "settle")}[args.experiment]
    options = {k: getattr(args, k) for k in keys if getattr(args, k) is not None}
    written = []
    for k, u in enumerate(refs):
        opts = dict(options)
        if args.experiment == "stepped-sine":
            opts["freq_hz"] = float(args.frequencies[k])
        try:
            log = make_log({"time": np.arange(u.size) / args.rate, column: u}, device=device, rate_hz=args.rate,
                           seed=None, experiment=f"plan_{args.experiment.replace('-', '_')}", options=opts,
                           signals=signals)
        except LogError as exc:
            raise UsageError(exc.problem, "name") from None
        path = args.out if len(refs) == 1 else args.out.with_name(f"{args.out.stem}_{k + 1:02d}{args.out.suffix}")
        write_log(log, path)
        written.append({"out": str(path), "samples": log.n_samples, "duration_s": log.n_samples / args.rate,
                        **({"freq_hz": opts["freq_hz"]} if "freq_hz" in opts else {})})
    summary = {"experiment": args.experiment, "device": device, "column": column, "rate_hz": args.rate,
               "logs": written, **options}
    if args.json:
        from tendyn.commands.shared import print_json

        print_json(summary, allow_nan=False)
    else:
        for w in written:
            print(f"{w['out']}: {w['samples']} samples, {w['duration_s']:.2f} s of {column}")
    return 0
