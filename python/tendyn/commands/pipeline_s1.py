"""`tendyn pipeline s1 [DEVICE] [--report DIR] [--logs DIR] [--json]` (default device ``mcgill_bench``): S1 items 2–7 of
issue 11 (:func:`tendyn.pipelines.s1.run_s1`), every response from the twin's logs; ``--logs DIR`` writes them. Registers ``s1`` into :mod:`tendyn.commands.pipeline`."""

from __future__ import annotations

from tendyn.commands.pipeline import Pipeline, publish, register_pipeline, say
from tendyn.errors import UsageError


def run(args) -> int:
    from tendyn.commands.shared import check_out_folder as _check_out_folder, load as _load
    from tendyn.pipelines.s1 import run_s1

    if str(args.device).lower().endswith((".csv", ".parquet")):
        raise UsageError(f"{args.device} is a log; pipeline s1 runs a twin (a tendon bench device). For a bench's "
                         "logs: `tendyn frf LOG... --input NAME --output NAME` and `tendyn identify-bench LOG... "
                         "--structure wiener --nonlinearity dead-zone --validate LOG...` (docs/bench-identification.md)",
                         "device")
    dev = _load(args.device)
    if dev.kind != "tendon_bench_2n":
        raise UsageError(f"{dev.name} is a {dev.kind} device; pipeline s1 needs a tendon bench", "device")
    out = _check_out_folder(args.report, "report") if args.report else None
    logs = _check_out_folder(args.logs, "logs") if getattr(args, "logs", None) else None
    report = run_s1(dev, quick=args.quick, progress=say, **({"logs_dir": logs} if logs is not None else {}))
    return publish(args, dict(report.summary), report.table(), {"s1_frf": report, **report.figures}, out, "s1.json",
                   device=dev, title=f"S1 pipeline on {dev.name}")


register_pipeline(Pipeline("s1", run, "mcgill_bench", "S1 McGill bench: sensitivities, loops, loop shaping",
                           writes_logs=True))


def register(subparsers) -> None:
    """The `pipeline` subparser belongs to tendyn.commands.pipeline; s1 is in its registry."""
    from tendyn.commands import pipeline

    pipeline.register(subparsers)
