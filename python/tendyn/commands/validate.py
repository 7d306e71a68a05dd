"""`tendyn validate DEVICE PARAMS.json LOG... [--json] [--report DIR] [--record [--db PATH]]`: an identified model
on other logs; with ``--record`` the per-joint errors go into the calibration history (``tendyn history``)."""

from __future__ import annotations

import json

import numpy as np

from tendyn.commands.args import existing_file
from tendyn.commands.history import add_record_arguments, check_record, record_result
from tendyn.errors import UsageError


def register(subparsers) -> None:
    p = subparsers.add_parser("validate", help="predict the torques of logs with identified parameters, per-joint "
                                               "relative error (tendyn identify --out)")
    p.add_argument("device", help="device file (.toml) or bundled device name (tx40, cea_branch, …)")
    p.add_argument("params", type=existing_file, metavar="PARAMS.json", help="parameters of `tendyn identify --out`")
    p.add_argument("logs", nargs="+", type=existing_file, metavar="LOG", help="log files (.parquet or .csv)")
    p.add_argument("--report", help="folder for report.html, the table, validate.json and one figure per log (one panel per joint)")
    p.add_argument("--json", action="store_true", help="print the errors as one JSON document on stdout")
    p.add_argument("--force", action="store_true",
                   help="use parameters or logs of another device (or of another version of its file) anyway")
    add_record_arguments(p)
    p.set_defaults(func=cmd_validate)


def metrics(results) -> dict:
    """What ``--record`` keeps: per joint ``relative_error[j]`` [-] (j the file's joint number) over all the logs,
    each log's relative error weighted by its samples (RMS over the logs: the error of one pooled record when
    the logs carry similar torque levels)."""
    n = np.array([r.time.size for r in results], float)
    out = {}
    for k, j in enumerate(results[0].joint_numbers):
        e = np.array([r.relative_error[k] for r in results], float)
        out[f"relative_error[{j}]"] = {"value": float(np.sqrt(np.sum(n * e ** 2) / n.sum())), "sigma": None,
                                       "unit": "-"}
    return out


def cmd_validate(args) -> int:
    from tendyn.io.params import ParamsError
    from tendyn.commands.shared import calibrated, check_out_folder as _check_out_folder, load as _load
    from tendyn.io import read_log
    from tendyn.io.logs import LogError

    dev = _load(args.device)
    check_record(args)
    if dev.kind != "serial":
        raise UsageError(f"{dev.name} is a {dev.kind}: validation needs a rigid serial device", "device")
    out = _check_out_folder(args.report) if args.report else None
    # the device with its identified parameters: PARAMS.json read once (device and file version checked unless
    # --force), the model built from that document
    cal = calibrated(dev, params=args.params, force=args.force)
    try:
        model = cal.identified_model()
    except ParamsError as exc:
        raise UsageError(str(exc)) from None
    from tendyn.commands.args import refuse_other_device
    from tendyn.io.logs import read_meta

    for path in args.logs:                      # every log of this device, before any work
        refuse_other_device(path.name, read_meta(path).get("device"), dev, args.force)
    results = []
    for path in args.logs:
        log = read_log(path)
        try:
            results.append(model.predict(log))
        except LogError as exc:
            raise LogError(exc.problem, file=path.name, column=exc.column) from None
    doc = {"device": dev.name, "params": str(args.params),
           "logs": [{"log": str(p), **r.to_dict()} for p, r in zip(args.logs, results)], "metrics": metrics(results)}
    text = "\n\n".join(f"{p.name}:\n{r.table()}" for p, r in zip(args.logs, results))
    if out is not None:
        from tendyn.report import section_of, write_report

        sections = [section_of(f"{p.name}: predicted vs measured torques", r, name=p.stem)
                    for p, r in zip(args.logs, results)]
        write_report(out, "validate", args, doc, "validate.json", sections, texts={"table.txt": text}, device=dev,
                     logs=[args.params, *args.logs], title=f"Validation of {args.params.name} on {dev.name}")
    record_result(args, dev, "validate", doc, source=", ".join(str(p) for p in args.logs))
    print(json.dumps(doc, indent=2) if args.json else text)
    return 0
