"""`tendyn log import RAW... --map MAP.toml --out LOG`: a lab's CSV, MATLAB, HDF5 files or ROS bags turned into a
log."""

from __future__ import annotations

import json
import sys

from tendyn.commands.args import existing_file, existing_input, not_an_input


def register(subparsers) -> None:
    log = subparsers.add_parser("log", help="experiment logs: import measured data")
    lsub = log.add_subparsers(dest="action", required=True)
    imp = lsub.add_parser("import", help="turn a lab's files (CSV, .mat, .h5, ROS bags) into a log with an import "
                                         "map (docs/logs.md)")
    imp.add_argument("raw", nargs="+", type=existing_input, metavar="RAW",
                     help="files of the lab: CSV, MATLAB .mat (v4-v7.3), HDF5 .h5/.hdf5, ROS 1 .bag, ROS 2 bag "
                          "folder, .mcap or .db3")
    imp.add_argument("--map", required=True, type=existing_file, help="import map (.toml)")
    imp.add_argument("--out", required=True, help="log file (.parquet or .csv)")
    imp.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    imp.set_defaults(func=cmd_log_import)


def cmd_log_import(args) -> int:
    from tendyn.io import check_log_path, write_log
    from tendyn.io.importer import import_logs

    out = not_an_input(check_log_path(args.out), [*args.raw, args.map])
    log = import_logs(args.raw, args.map)
    write_log(log, out)
    notes = log.meta["options"].get("import_notes", [])
    summary = {"out": str(out), "n_samples": log.n_samples, "rate_hz": log.meta["rate_hz"],
               "columns": list(log.columns), "device": log.meta["device"], "notes": notes}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{out}: {log.n_samples} samples at {log.meta['rate_hz']:g} Hz, columns {', '.join(log.columns)}",
              file=sys.stderr)
        for note in notes:
            print(f"  {note}", file=sys.stderr)
    return 0
