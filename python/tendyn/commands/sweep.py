"""`tendyn sweep DEVICE --param NAME=LO:HI:N ... [--amplitudes A,…] [--loop open|closed] [--metric M]
[--scheduler ADDRESS] --out TABLE.parquet [--json]`: design sweeps of the nonlinear twin on Dask (:mod:`tendyn.pipelines.sweep`)."""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from tendyn.commands.args import MAX_AMPLITUDE, check_device_limits, number, numbers, out_path
from tendyn.errors import UsageError

MAX_WORKERS = 4 * (os.cpu_count() or 1)
"""Most workers of a local cluster: more processes than this only wait for the CPUs (100 000 took minutes to set up)."""


def register(subparsers) -> None:
    from tendyn.pipelines.sweep import LOOPS, METRICS

    p = subparsers.add_parser("sweep", help="design sweep of a tendon-bench twin on Dask (table + figure)")
    p.add_argument("device", help="device file or bundled twin (a tendon bench)")
    p.add_argument("--param", action="append", required=True, metavar="NAME=LO:HI:N",
                   help="a bench field and its grid (repeat for a grid of several fields)")
    p.add_argument("--amplitudes", type=numbers(0.0, MAX_AMPLITUDE, lo_open=True, unit="N"),
                   default=(0.31, 0.38, 0.6, 2.0), metavar="A,…",
                   help="stepped-sine input amplitudes [N] [default: 0.31,0.38,0.6,2]; each ≤ the DEVICE's "
                        "bench.peak_force when its file declares one, else ≤ 1e4")
    p.add_argument("--loop", choices=LOOPS, default="open",
                   help="open: the twin alone; closed: also S1's loop-shaping controller C = L/P̂ in the twin")
    p.add_argument("--metric", choices=METRICS, default=None,
                   help="metric drawn over the grid [default: peak_shift_hz, closed_loop_spread_db with --loop closed]")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler [default: a local cluster]")
    p.add_argument("--workers", type=number(1, MAX_WORKERS, integer=True), default=2,
                   help=f"workers of the local cluster, 1 … {MAX_WORKERS} (4 per CPU) [default: 2]")
    p.add_argument("--out", type=out_path((".parquet",)), required=True,
                   help="table (.parquet); the figure (.png), the report (.html) and its JSON (.json) go beside it")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from tendyn.commands.shared import load as _load, print_json as _print_json
    from tendyn.device.tendon_bench import BENCH_MODEL_FIELDS
    from tendyn.pipelines.sweep import MAX_DESIGNS, parse_param, run_sweep
    from tendyn.report import warn, write_beside
    from tendyn.sim.tendon_bench import bench_model

    dev = _load(args.device)
    if dev.kind != "tendon_bench_2n":
        raise UsageError(f"{dev.name} is a {dev.kind} device; sweep needs a tendon bench", "device")
    check_device_limits("sweep", args, dev)
    params = {}
    fields = set(BENCH_MODEL_FIELDS)                # the plant's fields (not the limits: nothing to simulate)
    for text in args.param:
        try:
            name, grid = parse_param(text)
        except ValueError as exc:
            raise UsageError(str(exc), "param") from None
        if name not in fields:
            raise UsageError(f"unknown bench field {name!r} (known: {', '.join(sorted(fields))})", "param")
        if name in params:
            raise UsageError(f"{name} given twice", "param")
        for value in (grid.min(), grid.max()):      # the core validates every field (range, finiteness)
            try:
                bench_model(dev.replace(**{name: float(value)}))
            except ValueError as exc:
                raise UsageError(f"{name}={value:g}: {exc}", "param") from None
        params[name] = grid
    designs = math.prod(len(g) for g in params.values())
    if designs > MAX_DESIGNS:
        raise UsageError(f"{designs} designs: at most {MAX_DESIGNS} per sweep (MAX_DESIGNS)", "param")
    out = Path(args.out)                            # suffix, folder and writable checked by out_path
    metric = args.metric or ("closed_loop_spread_db" if args.loop == "closed" else "peak_shift_hz")
    if metric == "closed_loop_spread_db" and args.loop != "closed":
        raise UsageError("closed_loop_spread_db needs --loop closed", "metric")
    try:
        res = run_sweep(dev, params, amplitudes=args.amplitudes, metric=metric, loop=args.loop,
                        scheduler=args.scheduler, n_workers=args.workers, progress=not args.quiet)
    except ConnectionError as exc:
        raise UsageError(str(exc), "scheduler") from None
    doc = write_beside(res, res.to_dict(), args, dev, out, "sweep", f"Design sweep of {dev.name}",
                       f"{len(res.rows)} designs of {dev.name}, metric {res.metric}.")
    if args.json:
        _print_json(doc)
    else:
        print(res.table())
        print(f"table: {doc['table']}\nfigure: {doc['figure']}\nreport: {doc['report']}")
    sys.stdout.flush()
    warn("sweep", res.warnings)
    return 0

