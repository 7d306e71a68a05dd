"""`tendyn claims [--quick] [--json] [--report DIR] [--only C1,C22,…]`: which of the papers' 46 results hold today.

Runs the checks of :mod:`tendyn.claims` (the test suite's oracles: one definition) on the twins and prints claim /
paper value / tendyn value / band / status. Exit 1 when a claim that held fails (or its check raises); strict
expected failures are shown with their reason and do not fail the command."""

from __future__ import annotations

STATUSES = ("holds", "xfail", "XPASS", "FAILS", "ERROR", "skipped")


def register(subparsers) -> None:
    p = subparsers.add_parser("claims", help="check the papers' claims C1–C46 on the twins",
                              description="Run a check for each result C1–C46 of the three papers on the twins (the "
                                          "test suite's own checks, tendyn.claims) and print claim / paper value / "
                                          "tendyn value / band / status. Exit 1 when a claim that held fails; strict "
                                          "expected failures are shown with their reason.")
    p.add_argument("--quick", action="store_true",
                   help="under 2 minutes: cheaper settings where a band allows, the longest checks skipped")
    p.add_argument("--only", default=None, metavar="C1,C22,…",
                   help="run only these claims (ids; a claim's parts, e.g. C42:natural, come with it)")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.add_argument("--report", default=None, metavar="DIR", help="write report.html, claims.json and claims.txt into DIR")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)


def _select(only: str | None) -> list[str]:
    from tendyn.claims import claim_ids
    from tendyn.errors import UsageError

    keys = claim_ids()
    if only is None:
        return keys
    wanted = [w.strip().upper() for w in only.split(",") if w.strip()]
    known = {k.split(":")[0] for k in keys}
    bad = [w for w in wanted if w.split(":")[0] not in known]
    if bad or not wanted:
        raise UsageError(f"unknown claim {', '.join(bad) or '(none given)'} (known: C1…C46)", "only")
    return [k for k in keys if k.split(":")[0] in wanted or k.upper() in wanted]


def run(args) -> int:
    import time
    from datetime import datetime, timezone

    from tendyn.claims import REGISTRY, Context, check
    from tendyn.claims.report import summary_line, table, write_report
    from tendyn.progress import Steps

    keys = _select(args.only)
    out = None
    if args.report is not None:
        from tendyn.commands.shared import check_out_folder as _check_out_folder

        out = _check_out_folder(args.report, "report")
    ctx = Context(quick=args.quick)
    t0 = time.perf_counter()
    outcomes = []
    with Steps(len(keys), "claims", quiet=args.quiet) as steps:
        for k in keys:
            steps.step(f"{k}: {REGISTRY[k].statement[:60]}")
            o = check(k, ctx)
            outcomes.append(o)
            if o.bad:
                steps.write(f"[claims] {k} {o.status}: {'; '.join(o.failed)[:300]}")
    rows = [o.to_dict() for o in outcomes]
    doc = {"mode": "quick" if args.quick else "full", "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "version": _version(), "wall_s": round(time.perf_counter() - t0, 1),
           "counts": {s: sum(r["status"] == s for r in rows) for s in STATUSES},
           "skipped_in_quick_mode": [k for k in keys if REGISTRY[k].quick == "skip"],
           "claims": rows}
    if out is not None:
        write_report(out, doc)
        doc["report"] = str(out)
    if args.json:
        from tendyn.commands.shared import print_json as _print_json

        _print_json(doc)
    else:
        print(table(rows))
        print("\n" + summary_line(doc))
        if out is not None:
            print(f"report: {out}")
    return 1 if any(o.bad for o in outcomes) else 0


def _version() -> str:
    from tendyn.commands.shared import version as v

    return v()
