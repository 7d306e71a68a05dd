"""`tendyn identify DEVICE LOG... --out PARAMS.json`: base parameters of a device from measured logs (IDIM)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tendyn.commands.args import (boxes_file, check_needs, existing_file, number, out_path, refuse_other_device,
                                  treatment_option)
from tendyn.commands.history import add_record_arguments, check_record, record_result
from tendyn.errors import UsageError


def register(subparsers) -> None:
    p = subparsers.add_parser("identify", help="identify the base dynamic parameters from logs (IDIM least squares)")
    p.add_argument("device", help="device file (.toml) or bundled device name (tx40, cea_branch, …)")
    p.add_argument("logs", nargs="+", type=existing_file, metavar="LOG", help="log files (.parquet or .csv)")
    p.add_argument("--out", type=out_path((".json",)), help="parameters file (.json)")
    p.add_argument("--method", choices=("ols", "wls", "iv", "didim"), default="ols",
                   help="ols/wls: ordinary or weighted least squares (open-loop data, or closed loop with clean "
                        "encoders and a well-tuned filter; fastest). iv: IDIM-IV, instruments from the identified "
                        "model simulated in closed loop (noisy encoders in closed loop, filter not tuned: removes "
                        "the LS bias; needs the logged reference and the controller). didim: DIDIM, Gauss-Newton on "
                        "the closed-loop simulation error from the LS start (same needs; fits what the loop "
                        "outputs, torques or positions)")
    p.add_argument("--controller", type=existing_file, default=None, metavar="FILE.json",
                   help="iv/didim: the loop's controller as JSON ({\"kind\": \"pid\", \"kp\": [...], \"kd\": [...], "
                        "\"ki\": [...], \"space\": \"joint\"|\"motor\", \"velocity_cutoff_hz\", "
                        "\"velocity_feedforward\", \"gain\"}); default: the log's meta.options.controller (a twin's)")
    p.add_argument("--output", choices=("torque", "position"), default="torque",
                   help="didim: the simulated output fitted to the log, the controller's torques or the positions")
    p.add_argument("--jacobian", choices=("idm", "fd"), default="idm",
                   help="didim: Jacobian from the regressor at the simulated states (idm, Gautier's, one simulation "
                        "per iteration) or finite differences of the simulation (fd, b+1 runs batched; needed "
                        "for --output position)")
    p.add_argument("--max-iter", type=number(1, 1000, integer=True), default=20,
                   help="iv/didim: at most this many iterations (simulations)")
    p.add_argument("--tol", type=number(0.0, 1.0, lo_open=True), default=1e-3,
                   help="iv/didim: stop when |dX|/|X| falls below this [-]")
    p.add_argument("--consistent", action="store_true",
                   help="physically consistent (pseudo-inertia LMIs) always [default: only when the plain least "
                        "squares is not physical, with a warning saying so]")
    p.add_argument("--bounds", type=boxes_file, default=None, metavar="FILE.toml|FILE.json",
                   help="with --consistent: per-parameter boxes the fit respects, NAME = [lower, upper] in the "
                        "parameter's unit (standard names: M2, FV1, IAm6, a term's name; CX2/CY2/CZ2: link 2's "
                        "centre of mass [m]); docs/cli.md")
    p.add_argument("--plain", action="store_true",
                   help="the plain least squares even when it is not physical (its warnings say so)")
    p.add_argument("--cutoff-hz", type=number(0.0, None, lo_open=True, unit="Hz"), default=None,
                   help="-3 dB cut-off of the zero-phase Butterworth on positions [Hz] (default 5 x bandwidth)")
    p.add_argument("--decimate", type=number(1, 100000, integer=True), default=None,
                   help="decimation factor of the parallel filter (default rate / (10 x bandwidth))")
    p.add_argument("--velocity-threshold", type=number(0.0, None, unit="rad/s"), default=None,
                   help="drop a joint's samples below this |velocity| [rad/s], 0 keeps all (default: a fraction "
                        "of each joint's peak speed, 0.25 %%, 10 %% on elastic capstan drives, "
                        "tendyn.ident.treatment; the treatment line prints it)")
    p.add_argument("--velocities", choices=("logged", "differentiate"), default=None,
                   help="joint velocities from the log's qd_motor_<i> (or qd_joint_<j>) columns or from the "
                        "differentiated positions (default: the logged ones when the log has them)")
    treatment_option(p)
    p.add_argument("--essential", action="store_true", help="keep only the essential parameters")
    p.add_argument("--parameters", default=None, metavar="NAMES",
                   help="identify only these base parameters, comma-separated (e.g. S2 Table 4's 16); the others "
                        "are taken as zero")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler for a campaign of several logs (default: a local cluster; 'none': in process)")
    p.add_argument("--stream", action="store_true",
                   help="identify a Parquet log too large for memory chunk by chunk (normal equations, no W held)")
    p.add_argument("--force", action="store_true", help="use logs whose meta names another device")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--report", help="folder for report.html, the table, params.json and the measured-vs-estimated figure")
    p.add_argument("--json", action="store_true", help="print the parameters as one JSON document on stdout")
    add_record_arguments(p)
    p.set_defaults(func=cmd_identify)


def _device(arg: str):
    from tendyn.devices import load

    return load(arg)


def _scheduler(arg, n_logs: int):
    """None (in process) for one log or ``--scheduler none``; else "local" or the given address."""
    if arg is not None and arg.lower() == "none":
        return None
    if arg is not None:
        return arg
    return "local" if n_logs > 1 else None


def _parameters(text, model):
    """The names of ``--parameters`` (None: all base parameters), each checked against the device's base set."""
    if text is None:
        return None
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in model.base.names]
    if not names or unknown:
        raise UsageError(f"not base parameters of {model.device.name}: {', '.join(unknown) or '(none given)'} "
                         f"(base: {', '.join(model.base.names)})", "parameters")
    return names


def cmd_identify(args) -> int:
    from tendyn.device import compile_device
    from tendyn.ident import IDIM
    from tendyn.io import atomic_write_text, read_log

    check_needs("identify", args)
    dev = _device(args.device)
    if dev.kind != "serial":
        raise UsageError(f"{dev.name} is a {dev.kind}: identification needs a rigid serial device", "device")
    if args.out is not None and Path(args.out).suffix.lower() != ".json":
        raise UsageError(f"must end in .json (got {args.out})", "out")
    check_record(args)
    if args.report is not None:                 # checked before the fit, like --out (type=out_path)
        from tendyn.commands.shared import check_out_folder as _check_out_folder

        _check_out_folder(args.report, "report")
    if args.stream:
        if args.treatment != "tendyn":
            raise UsageError(f"--treatment {args.treatment} is not available with --stream (tendyn's only)",
                             "treatment")
        if args.method in ("iv", "didim"):
            raise UsageError(f"--method {args.method} simulates the loop over the whole log: not with --stream",
                             "stream")
        return _identify_stream(dev, args)
    if args.method in ("iv", "didim") and args.treatment != "tendyn":
        raise UsageError(f"--treatment {args.treatment} is not available with --method {args.method} (tendyn's "
                         "treatment only)", "treatment")
    if args.method not in ("iv", "didim"):
        for opt, default in (("controller", None), ("output", "torque"), ("jacobian", "idm")):
            if getattr(args, opt) != default:
                raise UsageError(f"is for --method iv or didim (got --method {args.method})", opt)
    if args.method == "didim" and args.output == "position" and args.jacobian != "fd":
        raise UsageError("position needs --jacobian fd (the regressor Jacobian is that of the torques)", "output")
    if args.consistent and args.plain:
        raise UsageError("--consistent and --plain exclude each other", "plain")
    controller = None
    if args.controller is not None:
        try:
            controller = json.loads(Path(args.controller).read_text())
            if not isinstance(controller, dict):
                raise ValueError("not a JSON object")
            from tendyn.ident.closed_loop import LoopController

            controller = LoopController.from_dict(controller)
        except (ValueError, KeyError, TypeError) as exc:
            raise UsageError(f"{args.controller}: not a controller ({exc})", "controller") from None
    from tendyn.ident.estimate import cached_model
    from tendyn.io import LogError

    logs = [read_log(p) for p in args.logs]     # read here: a bad log is exit 2 before any work
    model = cached_model(dev)
    for path, log in zip(args.logs, logs):      # the signals identification needs, named with their file
        refuse_other_device(path.name, log.meta["device"], dev, args.force)
        try:
            model.joint_signals(log)
        except LogError as exc:
            raise LogError(exc.problem, file=path.name, column=exc.column) from None
    bounds = None
    if args.bounds is not None:                 # the names and units against the device, before the fit
        from tendyn.ident.consistent import check_bounds

        try:
            bounds = check_bounds(model, args.bounds.bounds, args.bounds.units)
        except ValueError as exc:
            raise UsageError(f"{args.bounds.path}: {str(exc).removeprefix('bounds: ')}", "bounds") from None
    rate = logs[0].meta["rate_hz"]
    if args.cutoff_hz is not None and args.cutoff_hz >= rate / 2:
        raise UsageError(f"must be below half the log rate {rate / 2:g} Hz (got {args.cutoff_hz:g})", "cutoff_hz")
    est = IDIM(compile_device(dev), method=args.method, cutoff_hz=args.cutoff_hz,
               decimate=args.decimate,
               velocity_threshold=args.velocity_threshold, essential=args.essential,
               consistent=True if args.consistent else (False if args.plain else "auto"),
               scheduler=_scheduler(args.scheduler, len(logs)), progress=not args.quiet,
               parameters=_parameters(args.parameters, model), velocities=args.velocities or "auto",
               treatment=args.treatment, controller=controller, output=args.output, jacobian=args.jacobian,
               max_iter=args.max_iter, tol=args.tol, bounds=bounds)
    from tendyn.ident.closed_loop import ClosedLoopError
    from tendyn.ident.consistent import BoundsInfeasible

    try:
        est.fit(logs if len(logs) > 1 else logs[0])
    except ConnectionError as exc:
        raise UsageError(str(exc), "scheduler") from None
    except ClosedLoopError as exc:
        raise UsageError(str(exc), "method") from None
    except BoundsInfeasible as exc:
        raise UsageError(f"{args.bounds.path}: {exc}", "bounds") from None
    except ValueError as exc:
        if type(exc).__name__ in ("LogError",):
            raise
        raise UsageError(str(exc)) from None
    res = est.result_
    doc = _document(res, dev, args.logs)
    if bounds:
        doc["bounds"] = _bounds_document(args.bounds.path, bounds, est.standard_params_)
    record_result(args, dev, "identify", doc, source=", ".join(doc["logs"]))
    if args.out:
        atomic_write_text(args.out, json.dumps(doc, indent=2) + "\n")
    if args.report:
        _write_report(args, dev, res, doc)
    if args.json:
        print(json.dumps(doc, indent=2))
        _warn(res)
    else:
        print(res.table())
    print(res.treatment.describe() if res.treatment else "", file=sys.stderr)
    if bounds:
        b = doc["bounds"]
        print(f"bounds: {len(b['boxes'])} boxes from {b['file']}, {len(b['active'])} at a bound"
              + (f" ({', '.join(b['active'][:12])}{', …' if len(b['active']) > 12 else ''})" if b["active"] else ""),
              file=sys.stderr)
    return 0


def _bounds_document(path, bounds, standard) -> dict:
    """The boxes of ``--bounds`` as the parameters file records them, the estimate's value of each boxed quantity
    (standard parameter, or centre of mass MX_j / M_j [m]) and which boxes it sits on (within 1e-5 of the box's
    width, or of the bound's magnitude for a one-sided box)."""
    active, values = [], {}
    for name, (lo, hi) in bounds.items():
        com = name not in standard
        v = standard[f"M{name[1]}{name[2:]}"] / standard[f"M{name[2:]}"] if com and standard.get(
            f"M{name[2:]}") else standard.get(name)
        if v is None:
            continue
        values[name] = float(v)
        scale = 1e-5 * max(abs(hi - lo) if lo is not None and hi is not None else 0.0, abs(lo or 0.0), abs(hi or 0.0),
                           1e-12)
        if (lo is not None and v <= lo + scale) or (hi is not None and v >= hi - scale):
            active.append(name)
    return {"file": str(path), "boxes": {n: [lo, hi] for n, (lo, hi) in bounds.items()}, "values": values,
            "active": active}


def _write_report(args, dev, res, doc) -> None:
    """report.html (docs/reports.md), params.json, table.txt and torques.png into ``--report``, all or none."""
    from tendyn.report import section_of, write_report

    write_report(args.report, "identify", args, doc, "params.json",
                 [section_of("Base parameters and measured vs estimated torques", res, name="torques")],
                 texts={"table.txt": res.table()}, device=dev, logs=args.logs, title=f"Identification of {dev.name}")


def _document(res, dev, logs) -> dict:
    """PARAMS.json: the result, its provenance (format, device file and SHA-256) and the logs; it loads back
    with ``tendyn.ident.identified.IdentifiedModel.load``."""
    from tendyn.ident.identified import provenance
    from tendyn.io import to_jsonable

    return {**provenance(dev), **to_jsonable(res.to_dict()), "logs": [str(p) for p in logs]}


def _warn(res) -> None:
    """The implausible values on stderr when stdout holds JSON (the table holds them otherwise)."""
    for w in res.warnings:
        print(f"tendyn identify: warning: {w}", file=sys.stderr)


def _identify_stream(dev, args) -> int:
    from tendyn.device import compile_device
    from tendyn.ident.stream import StreamingIDIM
    from tendyn.io import atomic_write_text

    if len(args.logs) != 1 or args.logs[0].suffix.lower() != ".parquet":
        raise UsageError("needs exactly one .parquet log (read batch by batch)", "stream")
    for opt in ("consistent", "essential", "parameters"):
        if getattr(args, opt):
            raise UsageError(f"--{opt} is not available with --stream", opt)
    from tendyn.io.logs import read_meta

    refuse_other_device(args.logs[0].name, read_meta(args.logs[0])["device"], dev, args.force)   # as in memory
    est = StreamingIDIM(compile_device(dev), method=args.method, cutoff_hz=args.cutoff_hz,
                        decimate=args.decimate, velocity_threshold=args.velocity_threshold,
                        velocities=args.velocities or "auto").fit(args.logs[0])
    res = est.result_
    doc = _document(res, dev, args.logs)
    record_result(args, dev, "identify", doc, source=", ".join(doc["logs"]))
    if args.out:
        atomic_write_text(args.out, json.dumps(doc, indent=2) + "\n")
    if args.report:                         # a streamed fit keeps no samples: the figure is the %σ per parameter
        _write_report(args, dev, res, doc)
    print(json.dumps(doc, indent=2) if args.json else res.table())
    if args.json:
        _warn(res)
    print(res.treatment.describe(), file=sys.stderr)
    return 0
