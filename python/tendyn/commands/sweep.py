"""`tendyn sweep DEVICE --param NAME=LO:HI:N ... [--amplitudes A,…] [--metric M] [--scheduler ADDRESS]
--out TABLE.parquet [--json]`: design sweeps of the nonlinear twin on Dask (:mod:`tendyn.pipelines.sweep`)."""

from __future__ import annotations

from pathlib import Path

from tendyn.commands.args import numbers
from tendyn.errors import UsageError


def register(subparsers) -> None:
    from tendyn.pipelines.sweep import METRICS

    p = subparsers.add_parser("sweep", help="design sweep of a tendon-bench twin on Dask (table + figure)")
    p.add_argument("device", help="device file or bundled twin (a tendon bench)")
    p.add_argument("--param", action="append", required=True, metavar="NAME=LO:HI:N",
                   help="a bench field and its grid (repeat for a grid of several fields)")
    p.add_argument("--amplitudes", type=numbers(0.0, lo_open=True, unit="N"), default=(0.31, 0.38, 0.6, 2.0),
                   metavar="A,…", help="stepped-sine input amplitudes [N] [default: 0.31,0.38,0.6,2]")
    p.add_argument("--metric", choices=METRICS, default="peak_shift_hz", help="metric drawn over the grid")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler [default: a local cluster]")
    p.add_argument("--workers", type=int, default=2, help="workers of the local cluster [default: 2]")
    p.add_argument("--out", required=True, help="table (.parquet); the figure goes beside it (.png)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from tendyn.cli import _load, _print_json
    from tendyn.io import save_png
    from tendyn.pipelines.sweep import parse_param, run_sweep, write_table

    dev = _load(args.device)
    if dev.kind != "tendon_bench_2n":
        raise UsageError(f"{dev.name} is a {dev.kind} device; sweep needs a tendon bench", "device")
    params = {}
    fields = set(dev.to_dict()) - {"name", "description", "source"}
    for text in args.param:
        try:
            name, grid = parse_param(text)
        except ValueError as exc:
            raise UsageError(str(exc), "param") from None
        if name not in fields:
            raise UsageError(f"unknown bench field {name!r} (known: {', '.join(sorted(fields))})", "param")
        params[name] = grid
    out = Path(args.out)
    if out.suffix.lower() != ".parquet":
        raise UsageError(f"{out}: the table must be a .parquet file", "out")
    if not out.parent.exists() or not out.parent.is_dir():
        raise UsageError(f"{out.parent}: folder not found", "out")
    if args.workers < 1:
        raise UsageError(f"must be >= 1 (got {args.workers})", "workers")
    res = run_sweep(dev, params, amplitudes=args.amplitudes, metric=args.metric, scheduler=args.scheduler,
                    n_workers=args.workers, progress=not args.quiet)
    write_table(res, out)
    fig_path = out.with_suffix(".png")
    save_png(res.plot(), fig_path)
    doc = res.to_dict() | {"table": str(out), "figure": str(fig_path)}
    if args.json:
        _print_json(doc)
    else:
        print(res.table())
        print(f"table: {out}\nfigure: {fig_path}")
    return 0
