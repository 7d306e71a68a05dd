"""`tendyn pipeline s0 [DEVICE] [--report DIR] [--json]`: a paper's workflow on a twin in one command."""

from __future__ import annotations

import json
import sys


def register(subparsers) -> None:
    p = subparsers.add_parser("pipeline", help="a paper's end-to-end workflow on a twin (s0: identification + "
                                               "compensation, Fig. 7)")
    sub = p.add_subparsers(dest="action", required=True)
    s0 = sub.add_parser("s0", help="S0 on a twin: S1 vs S2, loss decomposition, Fig. 7 compensation and passivity")
    s0.add_argument("device", nargs="?", default="lexos", help="device file (.toml) or bundled twin [default: lexos]")
    s0.add_argument("--report", default=None, metavar="DIR", help="write figures and s0.json into DIR")
    s0.add_argument("--quick", action="store_true", help="skip the wall and over-compensation runs")
    s0.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    s0.set_defaults(func=cmd_pipeline_s0)


def cmd_pipeline_s0(args) -> int:
    from tendyn.cli import _load
    from tendyn.errors import CheckFailed
    from tendyn.io import to_jsonable
    from tendyn.pipelines.s0 import run_s0

    dev = _load(args.device)
    if dev.kind != "serial" or not getattr(dev, "transmissions", None):
        from tendyn.errors import UsageError

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
