"""`tendyn design DEVICE --vary NAME=LO:HI ... --objective Q ... [--constraint Q>=X ...] [--motors TABLE.csv]
--out DIR`: the Pareto front of a transmission design (:mod:`tendyn.pipelines.design`), an HTML report and one
device file per front design (``DIR/design_NNN.toml``, loadable by every command)."""

from __future__ import annotations

import argparse
from pathlib import Path

from tendyn.commands.args import existing_file, number
from tendyn.errors import UsageError

SCHEDULER_HELP = "where the islands run: 'none' this process, 'local' a local Dask cluster, or tcp://HOST:PORT"


def _vary(text: str):
    from tendyn.analysis.design_space import parse_vary

    try:
        return parse_vary(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _constraint(text: str):
    from tendyn.analysis.design_space import parse_constraint

    try:
        return parse_constraint(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _out_dir(text: str):
    from tendyn.commands.shared import check_out_folder as _check_out_folder

    try:
        return _check_out_folder(text, "out")
    except UsageError as exc:
        raise argparse.ArgumentTypeError(exc.problem) from None


def _scheduler(text: str) -> str:
    """``none``, ``local`` or a scheduler address ``tcp://HOST:PORT`` (also tls://, inproc://)."""
    import re

    if text in ("none", "local") or re.fullmatch(r"(tcp|tls|inproc|ucx)://\S+", text):
        return text
    raise argparse.ArgumentTypeError(f"must be none, local or tcp://HOST:PORT (got {text!r})")


def register(subparsers) -> None:
    from tendyn.analysis.design_space import QUANTITIES

    p = subparsers.add_parser("design", help="multi-objective transmission design (NSGA-II): Pareto front, report "
                                             "and one device file per front design")
    p.add_argument("device", help="device file or bundled twin (a tendon bench or a [[transmissions]] device)")
    p.add_argument("--vary", type=_vary, action="append", required=True, metavar="NAME=LO:HI",
                   help="a design value of the file and its range, LO < HI (bench: ratio, k1, …; cable device: "
                        "TRANSMISSION.FIELD, e.g. t2.reducer_ratio); repeat")
    p.add_argument("--objective", choices=list(QUANTITIES), action="append", required=True,
                   help="a quantity to optimise (its sense is fixed: friction and mass are minimised, forces, "
                        "stiffness, resonance, Z-width maximised); repeat")
    p.add_argument("--constraint", type=_constraint, action="append", default=None, metavar="Q>=X|Q<=X",
                   help="a bound on a quantity of the same vocabulary; repeat")
    p.add_argument("--motors", type=existing_file, default=None, metavar="TABLE.csv",
                   help="motor table (name,rotor_inertia,continuous_torque,peak_torque[,torque_constant][,damping]): "
                        "the motor becomes a design variable")
    p.add_argument("--rate-hz", type=number(0.0, 1e6, lo_open=True, unit="Hz"), default=1000.0,
                   help="control rate of the rendered wall (zwidth) [Hz] [default: 1000]")
    p.add_argument("--band-hz", type=number(0.0, 1e4, lo_open=True, unit="Hz"), default=40.0,
                   help="band edge of rejection and band_force [Hz] [default: 40, S1 §3.1]")
    p.add_argument("--population", type=number(4, 10_000, integer=True), default=64,
                   help="NSGA-II population per island, 4 … 10000 [default: 64]")
    p.add_argument("--generations", type=number(1, 100_000, integer=True), default=60,
                   help="NSGA-II generations, 1 … 100000 [default: 60]")
    p.add_argument("--islands", type=number(1, 256, integer=True), default=2,
                   help="independent seeded NSGA-II runs pooled into one front, 1 … 256 [default: 2]")
    p.add_argument("--seed", type=number(0, 2**31 - 1, integer=True), default=0, help="seed [default: 0]")
    p.add_argument("--scheduler", type=_scheduler, default="none", metavar="none|local|ADDRESS", help=SCHEDULER_HELP +
                   " [default: none]")
    p.add_argument("--workers", type=number(1, 64, integer=True), default=2,
                   help="workers of a local cluster, 1 … 64 [default: 2]")
    p.add_argument("--out", type=_out_dir, required=True, metavar="DIR",
                   help="folder: report.html, design.json, design.txt and design_NNN.toml per front design")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def _space(args):
    from tendyn.analysis.design_space import DesignSpace, read_motor_table
    from tendyn.commands.shared import load as _load

    dev = _load(args.device)
    vary = {}
    for name, lo, hi in args.vary:
        if name in vary:
            raise UsageError(f"{name} given twice", "vary")
        vary[name] = (lo, hi)
    motors = None
    if args.motors is not None:
        try:
            motors = read_motor_table(args.motors)
        except ValueError as exc:
            raise UsageError(str(exc), "motors") from None
    try:
        space = DesignSpace(dev, vary, motors, rate_hz=args.rate_hz, band_hz=args.band_hz)
    except KeyError as exc:
        raise UsageError(str(exc.args[0]), "vary") from None
    except ValueError as exc:
        raise UsageError(str(exc), "device") from None
    return dev, space


def _check_ranges(space, dev, quantities) -> None:
    """Each end of every range is a value the device file accepts (the loader's own domain check)."""
    import numpy as np

    for k, name in enumerate(space.vary):
        for end in (space.lower[k], space.upper[k]):
            x = space.shipped.copy()
            x[k] = end
            if space.motors:
                x[-1] = -1.0
            try:
                _load_text(space.device_text(x), dev)
            except ValueError as exc:
                why = str(exc).split(".toml: ", 1)[-1]       # the loader names the temporary file: not useful
                raise UsageError(f"{name}={end:g}: {why}", "vary") from None
            values = space.evaluate(x[None], quantities)
            bad = [q for q, v in values.items() if not np.all(np.isfinite(v))]
            if bad:
                raise UsageError(f"{name}={end:g}: {', '.join(bad)} not finite there (a degenerate design); "
                                 "narrow the range", "vary")


def _load_text(text: str, dev):
    """Load a device file text through the loader (its every check), from a temporary file."""
    import os
    import tempfile

    from tendyn.device import load_device

    fd, name = tempfile.mkstemp(suffix=".toml")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        return load_device(name)
    finally:
        os.unlink(name)


def run(args) -> int:
    from tendyn.pipelines.design import run_design
    from tendyn.report import publish
    from tendyn.report.publish import sections_of

    dev, space = _space(args)
    args.constraint = args.constraint or []      # default None: no list object shared by the calls of one parser
    for q in list(args.objective) + [c[0] for c in args.constraint]:
        why = space.why_not(q)
        if why:
            raise UsageError(why, "objective" if q in args.objective else "constraint")
    if len(set(args.objective)) != len(args.objective):
        raise UsageError("an objective is given twice", "objective")
    _check_ranges(space, dev, sorted(set(args.objective) | {c[0] for c in args.constraint}))
    scheduler = None if args.scheduler == "none" else args.scheduler
    try:
        res = run_design(space, args.objective, args.constraint, population=args.population,
                         generations=args.generations, islands=args.islands, seed=args.seed, scheduler=scheduler,
                         n_workers=args.workers, progress=not args.quiet)
    except ConnectionError as exc:
        raise UsageError(str(exc), "scheduler") from None
    texts = {}
    for i, x in enumerate(res.X):
        name = f"design_{i:03d}.toml"
        note = (f"Front design {i} of `tendyn design` on {dev.name} (objectives {', '.join(res.objectives)}); "
                f"values: {res.values[i]}")
        texts[name] = space.device_text(x, note).rstrip("\n")
        res.files.append(name)
    doc = res.to_dict()
    out = Path(args.out)
    table = res.table()
    secs = sections_of(table, {"pareto_front": res})
    from tendyn.report.publish import write_report

    write_report(out, "design", args, doc, "design.json", secs, texts={"design.txt": table, **texts}, device=dev,
                 title=f"Design of {dev.name}")
    doc["report"] = str(out / "report.html")
    return publish(args, doc, table, {}, None, "design.json", command="design", device=dev, sections=[])
