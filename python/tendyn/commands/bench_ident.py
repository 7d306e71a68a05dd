"""`tendyn frf` and `tendyn identify-bench`: frequency responses and block-oriented models from a bench's logs
(issue 21). No physics here: :mod:`tendyn.ident.frf` and :mod:`tendyn.ident.blockmodel` do the work.

::

    tendyn frf LOG... --input NAME --output NAME [--estimator h1|h2] [--window hann] [--segment N]
               [--overlap 0.5] [--confidence 0.95] [--band LO,HI] [--out FRF.json] [--figure FRF.png]
               [--report DIR] [--json]
    tendyn identify-bench LOG... --structure wiener|hammerstein|lure|push-pull|auto [--nonlinearity NAME] [--order N]
               --validate LOG... [--input NAME --output NAME] [--out MODEL.json] [--figure FIT.png]
               [--report DIR] [--json]
"""

from __future__ import annotations

import argparse
import json

from tendyn.commands import args as conv
from tendyn.errors import UsageError

DEFAULT_PAIRS = (("input_1", "output_1"), ("force_cmd", "force_tendon"))
"""(input, output) used when --input/--output are not given and the log has both columns."""

FRF_PAIRS = (("input_1", "output_1"), ("force_ref", "force_tendon"), ("force_cmd", "force_tendon"))
"""`frf`'s defaults: a closed-loop log (it has the reference `force_ref`) gives the closed loop F/r, the response
a bench measures in closed loop; `identify-bench` keeps :data:`DEFAULT_PAIRS` (the plant is command → force)."""


def _out(suffix: str):
    return conv.out_path((suffix,))


def _report_dir(text: str):
    """A report folder that exists or can be created (nothing is created here)."""
    from tendyn.commands.shared import check_out_folder as _check_out_folder

    try:
        return _check_out_folder(text, "report")
    except UsageError as exc:
        raise argparse.ArgumentTypeError(exc.problem) from None


def _band(text: str):
    lo, hi = conv.numbers(0.0, None, unit="Hz")(text) + (None,) * (2 - len(text.split(",")))
    if hi is None or not lo < hi:
        raise argparse.ArgumentTypeError(f"expected LO,HI with LO < HI [Hz] (got {text!r})")
    return lo, hi


def _read(paths):
    from tendyn.io import read_log

    return [read_log(p) for p in paths]


def _signals(logs, input_name, output_name, pairs=DEFAULT_PAIRS):
    """The (input, output) names: as given, or the first of ``pairs`` every log has."""
    from tendyn.io.logs import LogError

    if input_name is None or output_name is None:
        for i, o in pairs:
            if all(i in lg and o in lg for lg in logs):
                input_name, output_name = input_name or i, output_name or o
                break
        else:
            raise UsageError("give --input and --output (signal names: "
                             + ", ".join(n for n in logs[0].signal_names.values() if n != "time") + ")")
    for k, lg in enumerate(logs):
        for name, opt in ((input_name, "input"), (output_name, "output")):
            try:
                lg.resolve(name)
            except LogError as exc:
                raise UsageError(f"log {k + 1}: {exc.problem}", opt) from None
    return input_name, output_name


def _print_json(doc) -> None:
    from tendyn.io import to_jsonable

    print(json.dumps(to_jsonable(doc), indent=2))


def _publish(args, doc, result, what: str) -> int:
    """Write ``doc`` to ``--out`` and the figure to ``--figure`` (when given), the page to ``--report`` (the one
    path of every report, :func:`tendyn.report.publish`), print the JSON or the table."""
    from tendyn.io import atomic_write_text, save_png, to_jsonable

    if args.out is not None:
        atomic_write_text(args.out, json.dumps(to_jsonable(doc), indent=2) + "\n")
    if args.figure is not None:
        save_png(result.plot(), args.figure)
    if args.report is not None:
        from tendyn.report import publish

        command = args.command_name
        publish(args, doc, result.table(), {what: result}, args.report, f"{what}.json", f"{what}.txt",
                command=command, logs=list(args.logs) + list(getattr(args, "validate", None) or []),
                title=f"tendyn {command}")
        for name, path in ((what, args.out), ("figure", args.figure)):
            if path is not None and not args.json:
                print(f"{name}: {path}")
        return 0
    if args.json:
        _print_json(doc)
        return 0
    print(result.table())
    for name, path in ((what, args.out), ("figure", args.figure)):
        if path is not None:
            print(f"{name}: {path}")
    return 0


# ---- frf --------------------------------------------------------------------------------------------------

def add_frf_arguments(sub) -> None:
    p = sub.add_parser("frf", help="H1/H2 frequency response, coherence and confidence band from logs")
    p.add_argument("logs", nargs="+", type=conv.existing_file, metavar="LOG",
                   help="logs (.csv/.parquet): broadband (PRBS, chirp, multisine, noise) or one stepped-sine tone each")
    p.add_argument("--input", default=None, help="input signal: a column or its meta.signals name "
                   "(default input_1, or force_ref on a closed-loop tendon-bench log, else force_cmd)")
    p.add_argument("--output", default=None, help="output signal (default output_1, or force_tendon)")
    p.add_argument("--estimator", choices=("h1", "h2"), default="h1",
                   help="h1 = S_uy/S_uu (output noise), h2 = S_yy/S_yu (input noise); default h1")
    p.add_argument("--window", default="hann", help="Welch window (a scipy window name; default hann)")
    p.add_argument("--segment", type=conv.number(16, None, integer=True), default=None, metavar="N",
                   help="Welch segment length [samples] (default: each broadband log in 8)")
    p.add_argument("--overlap", type=conv.number(0.0, 0.95), default=0.5, help="segment overlap fraction (default 0.5)")
    p.add_argument("--confidence", type=conv.number(0.5, 0.999), default=0.95, help="band level (default 0.95)")
    p.add_argument("--band", type=_band, default=None, metavar="LO,HI", help="keep LO…HI [Hz]")
    p.add_argument("--out", type=_out(".json"), default=None, help="write the FRF as JSON")
    p.add_argument("--figure", type=_out(".png"), default=None, help="magnitude with band, phase, coherence (PNG)")
    p.add_argument("--report", type=_report_dir, default=None, metavar="DIR",
                   help="write report.html (figure, table, warnings), data.json, data.txt and data.png into DIR")
    p.add_argument("--json", action="store_true", help="print the FRF as one JSON document on stdout")
    p.set_defaults(func=run_frf, command_name="frf")


def run_frf(args) -> int:
    from scipy.signal import get_window

    from tendyn.ident.frf import frf_from_logs

    try:
        get_window(args.window, 16)
    except ValueError as exc:
        raise UsageError(f"unknown window {args.window!r} ({exc})", "window") from None
    logs = _read(args.logs)
    i, o = _signals(logs, args.input, args.output, FRF_PAIRS)
    conv.check_signals("frf", args, logs, (i, o), args.logs)
    try:
        frf = frf_from_logs(logs, i, o, estimator=args.estimator, nperseg=args.segment, window=args.window,
                            overlap=args.overlap, confidence=args.confidence, band_hz=args.band)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    return _publish(args, frf.to_dict(), frf, "data")


# ---- identify-bench --------------------------------------------------------------------------------------

def add_identify_bench_arguments(sub) -> None:
    from tendyn.ident.blockmodel import NONLINEARITY_NAMES, STRUCTURES

    p = sub.add_parser("identify-bench", help="Wiener/Hammerstein/Lur'e model (linear block + static nonlinearity) "
                                              "by output error, validated by simulation on other logs")
    p.add_argument("logs", nargs="+", type=conv.existing_file, metavar="LOG", help="estimation logs")
    p.add_argument("--structure", choices=STRUCTURES + ("auto",), required=True,
                   help="wiener: G then f; hammerstein: f then G; lure: G with f in its feedback (Coulomb "
                        "friction of the output's motion at G's input; --nonlinearity coulomb); push-pull: two "
                        "lure loops of one G and one friction fed the half-waves max(u,0), min(u,0) (a class-B "
                        "2N drive: each motor its half-wave, each node its friction); auto: the structure "
                        "(wiener dead-zone, lure, push-pull coulomb and coulomb-tension) with the lowest NRMS on the --validate logs (record "
                        "them at another amplitude than the estimation logs)")
    p.add_argument("--nonlinearity", choices=NONLINEARITY_NAMES, default=None,
                   help="the static nonlinearity f (required unless --structure auto; lure, push-pull: coulomb, or "
                        "coulomb-tension: a friction level linear in the branch's output, F + mu s y, the "
                        "recursion at 4 steps a sample: holds across amplitudes on the twins)")
    p.add_argument("--order", type=conv.number(1, 12, integer=True), default=None,
                   help="order of G(z) (default: chosen in 1…--max-order by the validation NRMS)")
    p.add_argument("--max-order", type=conv.number(1, 12, integer=True), default=4, help="default 4")
    p.add_argument("--degree", type=conv.number(2, 9, integer=True), default=3, help="polynomial degree (default 3)")
    p.add_argument("--validate", nargs="+", type=conv.existing_file, required=True, metavar="LOG",
                   help="validation logs (simulated from rest with the fitted model: RMS and NRMS)")
    p.add_argument("--input", default=None, help="input signal (default input_1, or force_cmd)")
    p.add_argument("--output", default=None, help="output signal (default output_1, or force_tendon)")
    p.add_argument("--shift", type=conv.number(-1000, 1000, integer=True), default=0, metavar="N",
                   help="pair output k with input k + N [samples]: 0 when a logged command is held from its "
                        "time on, 1 when it was held up to its time (the twins' logs); default 0")
    p.add_argument("--out", type=_out(".json"), default=None, help="write the model as JSON")
    p.add_argument("--figure", type=_out(".png"), default=None, help="measured vs simulated validation output")
    p.add_argument("--report", type=_report_dir, default=None, metavar="DIR",
                   help="write report.html (figure, table, warnings), model.json, model.txt and model.png into DIR")
    p.add_argument("--json", action="store_true", help="print the model as one JSON document on stdout")
    p.set_defaults(func=run_identify_bench, command_name="identify-bench")


def run_identify_bench(args) -> int:
    from tendyn.ident.blockmodel import NONLINEARITY_NAMES, BlockModel, records_from_logs

    if args.structure != "auto" and args.nonlinearity is None:
        raise UsageError(f"required with --structure {args.structure} (one of {', '.join(NONLINEARITY_NAMES)}; "
                         "--structure auto chooses it)", "nonlinearity")
    fit_logs, val_logs = _read(args.logs), _read(args.validate)
    i, o = _signals(fit_logs + val_logs, args.input, args.output)
    conv.check_signals("identify-bench", args, fit_logs + val_logs, (i, o), list(args.logs) + list(args.validate))
    try:
        recs, units = records_from_logs(fit_logs, i, o, args.shift)
        val, vunits = records_from_logs(val_logs, i, o, args.shift)
        if vunits != units:
            raise ValueError(f"the validation logs' units {vunits} differ from the estimation logs' {units}")
        model = BlockModel(args.structure, args.nonlinearity or "coulomb", order=args.order, max_order=args.max_order,
                           degree=args.degree).fit(recs, validation=val)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    res = model.result_
    res.units = units
    doc = res.to_dict() | {"input": i, "output": o, "shift": args.shift, "logs": [str(p) for p in args.logs],
                           "validation_logs": [str(p) for p in args.validate]}
    return _publish(args, doc, res, "model")


def register(subparsers) -> None:
    """Found by :func:`tendyn.cli.build_parser`."""
    add_frf_arguments(subparsers)
    add_identify_bench_arguments(subparsers)
