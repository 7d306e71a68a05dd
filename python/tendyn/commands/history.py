"""`tendyn history DEVICE [--db PATH] [--parameter NAME]... [--csv OUT.csv] [--parquet OUT.parquet] [--plot OUT.png]
[--report DIR] [--json]`: a device's calibration history (:mod:`tendyn.ident.history`)."""

from __future__ import annotations

from pathlib import Path

from tendyn.errors import UsageError


def add_record_arguments(p) -> None:
    """``--record`` and ``--db`` of the commands whose result can be recorded."""
    p.add_argument("--record", action="store_true",
                   help="add the result to the calibration history (tendyn history DEVICE)")
    p.add_argument("--db", default=None, metavar="PATH",
                   help="history database [default: history.sqlite in the user's data folder]")


def check_record(args) -> None:
    """Before any work: ``--db`` only with ``--record``, and a database that opens (created if new)."""
    if not getattr(args, "record", False):
        if getattr(args, "db", None):
            raise UsageError("--db needs --record", "db")
        return
    from tendyn.ident.history import check_db

    try:
        check_db(args.db)                       # creates nothing: a refusal later leaves no empty database
    except (ValueError, OSError) as exc:
        raise UsageError(str(exc), "db") from None


def record_result(args, device, kind: str, doc: dict, source: str) -> None:
    """Record ``doc`` when ``--record`` was given (checked by :func:`check_record` first)."""
    if getattr(args, "record", False):
        from tendyn.ident.history import record

        record(device, kind, doc, db=args.db, source=source)


def register(subparsers) -> None:
    p = subparsers.add_parser("history", help="a device's recorded identifications over time (drift beyond 3σ)")
    p.add_argument("device", help="device file or bundled twin (records are keyed by the file's hash)")
    p.add_argument("--db", default=None, metavar="PATH",
                   help="history database [default: history.sqlite in the user's data folder]")
    p.add_argument("--parameter", action="append", default=None, metavar="NAME",
                   help="show only this parameter (repeat)")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="export the rows as CSV")
    p.add_argument("--parquet", default=None, metavar="OUT.parquet", help="export the rows as Parquet")
    p.add_argument("--plot", default=None, metavar="OUT.png", help="plot each parameter over time")
    p.add_argument("--report", default=None, metavar="DIR",
                   help="write report.html (figure, table, drifts as warnings), history.json and history.txt into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def _check_out(path: str | None, suffix: str, option: str) -> Path | None:
    if path is None:
        return None
    import argparse

    from tendyn.commands.args import out_path

    try:                                        # suffix, an existing folder, not a folder itself, writable
        return out_path((suffix,))(path)
    except argparse.ArgumentTypeError as exc:
        raise UsageError(str(exc), option) from None


def run(args) -> int:
    from tendyn.commands.shared import check_out_folder as _check_out_folder, load as _load, print_json as _print_json
    from tendyn.io import atomic_write_bytes, atomic_write_text, save_png
    from tendyn.ident.history import history

    dev = _load(args.device)
    csv, parquet = _check_out(args.csv, ".csv", "csv"), _check_out(args.parquet, ".parquet", "parquet")
    png = _check_out(args.plot, ".png", "plot")
    report = _check_out_folder(args.report, "report") if args.report else None
    if args.db is not None and not Path(args.db).is_file():
        raise UsageError(f"{args.db}: no such database", "db")
    try:
        h = history(dev, db=args.db, names=args.parameter)
    except ValueError as exc:
        raise UsageError(str(exc), "db") from None
    if args.parameter:
        missing = sorted(set(args.parameter) - set(h.names()))
        if missing:
            raise UsageError(f"no record of {', '.join(missing)} for {dev.name}", "parameter")
    for option, given in (("plot", png), ("report", report)):
        if given and not h.rows:
            raise UsageError(f"nothing recorded for {dev.name}: no {option}", option)
    if csv:
        atomic_write_text(csv, h.to_csv())
    if parquet:
        atomic_write_bytes(parquet, h.to_parquet())
    if png:
        save_png(h.plot(), png)
    if report:
        from tendyn.report import publish

        return publish(args, h.to_dict(), h.table(), {"history": h}, report, "history.json", "history.txt",
                       command="history", device=dev, title=f"Calibration history of {dev.name}")
    if args.json:
        _print_json(h.to_dict())
    else:
        print(h.table() if h.rows else f"{dev.name}: nothing recorded ({h.device_hash[:12]})")
    return 0
