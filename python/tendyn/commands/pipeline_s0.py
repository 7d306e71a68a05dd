"""`tendyn pipeline s0 [DEVICE]`: S0 on a cable twin — S1 vs S2, loss decomposition, Fig. 7 compensation."""

from __future__ import annotations

import json
import sys

from tendyn.commands.pipeline import Pipeline, register_pipeline


def run_pipeline_s0(args) -> int:
    from tendyn.cli import _load
    from tendyn.errors import CheckFailed, UsageError
    from tendyn.io import to_jsonable
    from tendyn.pipelines.s0 import run_s0

    dev = _load(args.device)
    if dev.kind != "serial" or not dev.transmissions:
        raise UsageError(f"{dev.name} has no cable transmissions (pipeline s0 needs a cable-driven chain)", "device")
    doc = run_s0(dev, report=args.report, quick=args.quick)
    table = doc.pop("_table")
    if args.json:
        print(json.dumps(to_jsonable(doc), indent=2))
    else:
        print(table)
        comp = doc["compensation"]
        print(f"\nC11: joint-1 torque reduction {100 * comp['reduction_joint1']:.1f} % (claim > 50 %)")
        if "report" in doc:
            print(f"report: {doc['report']['figure']}, {doc['report']['data']}")
    sys.stdout.flush()
    if not doc["compensation"]["reduction_joint1"] > 0.5:
        raise CheckFailed(f"C11: reduction {doc['compensation']['reduction_joint1']:.3f} is not > 0.5")
    return 0


register_pipeline(Pipeline("s0", run_pipeline_s0, "lexos",
                           "S1 vs S2 friction identification, loss decomposition, Fig. 7 compensation (L-EXOS)"))
