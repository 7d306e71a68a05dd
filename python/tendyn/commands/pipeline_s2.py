"""`tendyn pipeline s2 [DEVICE] [--report DIR] [--json]` (default device ``cea_branch``): S2 items 1–5 and 8 of
issue 10 (:func:`tendyn.pipelines.s2.run_s2`). Registers ``s2`` into :mod:`tendyn.commands.pipeline`."""

from __future__ import annotations

from tendyn.commands.pipeline import Pipeline, publish, register_pipeline, say
from tendyn.errors import UsageError


def run(args) -> int:
    from tendyn.commands.shared import check_out_folder as _check_out_folder, load as _load
    from tendyn.pipelines.s2 import run_s2

    dev = _load(args.device)
    if dev.kind != "serial" or not dev.drives:
        raise UsageError(f"{dev.name} has no capstan [[drives]]; pipeline s2 needs a device like cea_branch", "device")
    out = _check_out_folder(args.report, "report") if args.report else None
    report = run_s2(dev, quick=args.quick, progress=say)
    return publish(args, dict(report.summary), report.table(), report.figures, out, "s2.json", "s2.txt",
                   device=dev, title=f"S2 pipeline on {dev.name}")


register_pipeline(Pipeline("s2", run, "cea_branch", "S2 CEA branch: capstan stiffness, friction, Table 4"))


def register(subparsers) -> None:
    """The `pipeline` subparser belongs to tendyn.commands.pipeline; s2 is in its registry."""
    from tendyn.commands import pipeline

    pipeline.register(subparsers)
