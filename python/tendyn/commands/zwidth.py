"""`tendyn zwidth DEVICE [--compensator X.comp | --friction FRICTION.json [--shares SHARES.json]] [--stiffness LO:HI:N] [--damping LO:HI:N] [--modes M,…]
[--scheduler ADDRESS] [--out TABLE.parquet] [--json]`: the Z-width of the rendered wall on the twin, on Dask
(:mod:`tendyn.pipelines.zwidth`)."""

from __future__ import annotations

from pathlib import Path

from tendyn.commands.args import check_needs, existing_file, number, out_path
from tendyn.errors import UsageError


def register(subparsers) -> None:
    from tendyn.pipelines.zwidth import DEFAULT_DAMPING, DEFAULT_STIFFNESS, MODES

    p = subparsers.add_parser("zwidth", help="stable wall stiffness/damping region (Z-width) on the twin, on Dask")
    p.add_argument("device", help="device file or bundled twin (a serial device with cable transmissions or capstan drives)")
    p.add_argument("--compensator", default=None, metavar="X.comp",
                   help="compensator model file [default: the device's own, k = 0.9]")
    p.add_argument("--friction", type=existing_file, default=None, metavar="FRICTION.json",
                   help="identified friction (identify-friction's FRICTION.json or decompose --json): the compensator "
                        "of every mode uses it instead of the device file's losses (the twin keeps the file's); not "
                        "with --compensator")
    p.add_argument("--shares", type=existing_file, default=None, metavar="SHARES.json",
                   help="loss shares p, p' per branch (tendyn.shares/1) for splitting --friction [default: from the "
                        "construction]")
    k, b = DEFAULT_STIFFNESS, DEFAULT_DAMPING
    p.add_argument("--stiffness", default=f"{k[0]:g}:{k[1]:g}:{k[2]}", metavar="LO:HI:N",
                   help=f"wall stiffness grid K [N/m], log-spaced over a decade or more [default: {k[0]:g}:{k[1]:g}:{k[2]}]")
    p.add_argument("--damping", default=f"{b[0]:g}:{b[1]:g}:{b[2]}", metavar="LO:HI:N",
                   help=f"wall damping grid B [N·s/m] [default: {b[0]:g}:{b[1]:g}:{b[2]}]")
    p.add_argument("--modes", default=",".join(MODES), metavar="M,…",
                   help=f"compensation modes, among {', '.join(MODES)} [default: all]")
    p.add_argument("--push", type=number(0.0, 1000.0, lo_open=True, unit="N"), default=None,
                   help="constant hand force pressing the handle into the wall [N] [default: 10, or half of what "
                        "the motors hold along the wall normal when that is less than 20]")
    p.add_argument("--horizon", type=number(0.05, 60.0, unit="s"), default=0.6,
                   help="length of each run [s] [default: 0.6]")
    p.add_argument("--tolerance", type=number(0.0, 0.1, lo_open=True, unit="m"), default=1e-4,
                   help="peak-to-peak height of a limit cycle [m] [default: 1e-4]")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler [default: a local cluster; 'none': in process]")
    from tendyn.commands.sweep import MAX_WORKERS

    p.add_argument("--workers", type=number(1, MAX_WORKERS, integer=True), default=2,
                   help=f"workers of the local cluster, 1 … {MAX_WORKERS} (4 per CPU) [default: 2]")
    p.add_argument("--out", type=out_path((".parquet",)), default=None, metavar="TABLE.parquet",
                   help="write the table (.parquet) and the figure beside it (.png)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def _grid(text: str, option: str, lo_min: float):
    from tendyn.pipelines.sweep import parse_param

    try:
        _, grid = parse_param(f"{option}={text}")
    except ValueError as exc:
        raise UsageError(str(exc), option) from None
    if grid.min() < lo_min or len(grid) > 10000:
        raise UsageError(f"values must be >= {lo_min:g} and at most 10000 points (got {text})", option)
    return grid


def run(args) -> int:
    from tendyn import _core
    from tendyn.commands.shared import calibrated, load as _load, print_json as _print_json
    from tendyn.ident.calibrated import CalibrationError
    from tendyn.pipelines.zwidth import MODES, run_zwidth

    check_needs("zwidth", args)
    dev = _load(args.device)
    if dev.kind != "serial" or not (getattr(dev, "transmissions", None) or getattr(dev, "drives", None)):
        raise UsageError(f"{dev.name} is not a serial device with cable transmissions or capstan drives", "device")
    stiffness = _grid(args.stiffness, "stiffness", 0.0)
    damping = _grid(args.damping, "damping", 0.0)
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    if not modes or any(m not in MODES for m in modes) or len(set(modes)) != len(modes):
        raise UsageError(f"a comma-separated subset of {', '.join(MODES)} (got {args.modes!r})", "modes")
    text = None
    if args.compensator is not None:
        path = Path(args.compensator)
        try:
            text = path.read_text(encoding="utf-8")
            _core.parse_compensator_model(text, path.name, dev.name)
        except (OSError, UnicodeDecodeError) as exc:
            raise UsageError(f"{path}: cannot read: {exc.strerror if isinstance(exc, OSError) else exc}",
                             "compensator") from None
        except ValueError as exc:
            raise UsageError(str(exc), "compensator") from None
    # the device with its identified friction laid over it, FRICTION.json read once (file's losses without it)
    cal = calibrated(dev, args.friction, shares=args.shares)
    try:
        cal.loss_model()            # a differential's motor-side friction: refused, not mis-decomposed
    except CalibrationError as exc:
        raise UsageError(str(exc), "friction") from None
    out = Path(args.out) if args.out else None     # suffix, folder and writable checked by out_path
    from tendyn.pipelines.sweep import MAX_DESIGNS

    designs = len(stiffness) * len(damping) * len(modes)
    if designs > MAX_DESIGNS:
        raise UsageError(f"{designs} wall designs (stiffness x damping x modes): at most {MAX_DESIGNS} (MAX_DESIGNS)",
                         "stiffness")
    scheduler = None if args.scheduler is None else args.scheduler
    import sys

    from tendyn.pipelines.zwidth import default_push, max_push

    push = args.push
    if push is None:
        push, note = default_push(dev)
        if note:
            print(f"tendyn: note: {note}", file=sys.stderr)
    else:
        fmax = max_push(dev)
        if push > fmax:
            print(f"tendyn: warning: --push {push:g} N is more than the motors hold along the wall normal ({fmax:.3g} N "
                  "at their peak torques): the wall cannot hold it and every point may come out unstable",
                  file=sys.stderr)
    try:
        res = run_zwidth(cal, stiffness=stiffness, damping=damping, modes=modes, compensator_text=text,
                         scheduler=scheduler, n_workers=args.workers, progress=not args.quiet, push=push,
                         horizon=args.horizon, tolerance=args.tolerance)
    except ConnectionError as exc:
        raise UsageError(str(exc), "scheduler") from None
    doc = res.to_dict()
    if out is not None:
        from tendyn.report import write_beside

        doc = write_beside(res, doc, args, dev, out, "zwidth", f"Z-width of {dev.name}",
                           f"{len(res.rows)} walls of {dev.name} at {res.rate_hz:g} Hz; {res.criterion}.")
    if args.json:
        _print_json(doc)
    else:
        print(res.table())
        if out is not None:
            print(f"table: {doc['table']}\nfigure: {doc['figure']}\nreport: {doc['report']}")
    return 0
