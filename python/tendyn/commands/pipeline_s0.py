"""`tendyn pipeline s0 [DEVICE]`: S0 on a cable twin — S1 vs S2, loss decomposition, Fig. 7 compensation."""

from __future__ import annotations


from tendyn.commands.pipeline import Pipeline, publish, register_pipeline


def run_pipeline_s0(args) -> int:
    from tendyn.commands.shared import load as _load
    from tendyn.errors import CheckFailed, UsageError
    from tendyn.pipelines.s0 import run_s0

    dev = _load(args.device)
    if dev.kind != "serial" or not (dev.transmissions or dev.drives):
        raise UsageError(f"{dev.name} has no cable transmissions or capstan drives (pipeline s0 needs a cable- or "
                         "capstan-driven chain)", "device")
    doc = run_s0(dev, quick=args.quick)
    table, figures = doc.pop("_table"), doc.pop("_figures")
    comp = doc["compensation"]
    if not args.json:
        print(table)
        print(f"\nC11: joint-1 torque reduction {100 * comp['reduction_joint1']:.1f} % (claim > 50 %)")
    publish(args, doc, table, figures, args.report, "s0.json", device=dev, title=f"S0 pipeline on {dev.name}",
            quiet_table=True)
    if not doc["compensation"]["reduction_joint1"] > 0.5:
        raise CheckFailed(f"C11: reduction {doc['compensation']['reduction_joint1']:.3f} is not > 0.5")
    return 0


register_pipeline(Pipeline("s0", run_pipeline_s0, "lexos",
                           "S1 vs S2 friction identification, loss decomposition, Fig. 7 compensation (L-EXOS)"))
