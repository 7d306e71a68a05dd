"""`tendyn pipeline s2 [DEVICE] [--report DIR] [--json]` (default device ``cea_branch``): S2 items 1–5 and 8 of
issue 10 (:func:`tendyn.pipelines.s2.run_s2`). Registers ``s2`` into :mod:`tendyn.commands.pipeline`."""

from __future__ import annotations

import json

from tendyn.commands.pipeline import Pipeline, register_pipeline, say
from tendyn.errors import UsageError


def run(args) -> int:
    from tendyn.cli import _check_out_folder, _load, _print_json
    from tendyn.pipelines.s2 import run_s2

    dev = _load(args.device)
    if dev.kind != "serial" or not dev.drives:
        raise UsageError(f"{dev.name} has no capstan [[drives]]; pipeline s2 needs a device like cea_branch", "device")
    out = _check_out_folder(args.report) if args.report else None
    report = run_s2(dev, quick=args.quick, progress=say)
    doc = dict(report.summary)
    if out is not None:
        from tendyn.io import atomic_write_text, save_png, to_jsonable
        from tendyn.io.files import all_or_none

        with all_or_none(out) as stage:
            for name, res in report.figures.items():
                save_png(res.plot(), stage / f"{name}.png")
            atomic_write_text(stage / "s2.json", json.dumps(to_jsonable(doc)))
            atomic_write_text(stage / "s2.txt", report.table() + "\n")
        doc["report"] = str(out)
    if args.json:
        _print_json(doc)
    else:
        print(report.table())
        if out is not None:
            print(f"report: {out}")
    return 0


register_pipeline(Pipeline("s2", run, "cea_branch", "S2 CEA branch: capstan stiffness, friction, Table 4"))


def register(subparsers) -> None:
    """The `pipeline` subparser belongs to tendyn.commands.pipeline; s2 is in its registry."""
    from tendyn.commands import pipeline

    pipeline.register(subparsers)
