"""`make realdata`: every real data set of ../shared/external-data against its peers' published numbers.

Discovers the dataset modules ``benchmarks/realdata/<dataset>.py`` (every module here but this one and names
starting with ``_``). Each exposes

* ``rows(shared: Path) -> list[dict]``: one row per compared item, keys ``dataset, peer, metric, item,
  peer_value, tendyn_preset, tendyn_default, unit`` (``tendyn_preset``: tendyn with the peer's treatment,
  ``--treatment NAME``; ``tendyn_default``: tendyn's own defaults; None where not measured);
* optionally ``figures(shared: Path) -> list[(title, result)]``: measured vs predicted torques (any object with
  ``plot()``/``table()``, e.g. :class:`tendyn.ident.identified.TorquePrediction`).

Writes ``benchmarks/realdata.json`` (``{"rows": [...], "datasets": {name: {"seconds": ..., "skipped": ...}}}``)
and an HTML page (the report publisher, ``--out DIR``, default build/realdata/), prints the table. A data set
whose files are absent is skipped with the reason. ``--only NAME,…`` runs a subset.

    python benchmarks/realdata/run.py [--shared PATH] [--out DIR] [--json PATH] [--only emps,tx40]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
KEYS = ("dataset", "peer", "metric", "item", "peer_value", "tendyn_preset", "tendyn_default", "unit")
"""The keys of every row (the interface of the dataset modules)."""


def shared_folder(given=None) -> Path:
    """../shared of the repository (or TENDYN_SHARED, or ``given``)."""
    if given:
        return Path(given)
    if os.environ.get("TENDYN_SHARED"):
        return Path(os.environ["TENDYN_SHARED"])
    return HERE.parents[2] / "shared"


def dataset_modules() -> dict:
    """name → module of every dataset module beside this file."""
    out = {}
    for path in sorted(HERE.glob("*.py")):
        if path.stem == "run" or path.stem.startswith("_"):
            continue
        spec = importlib.util.spec_from_file_location(f"realdata_{path.stem}", path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        if hasattr(mod, "rows"):
            out[path.stem] = mod
    return out


def check_rows(name: str, rows) -> list[dict]:
    """The rows of one module, each with every key of :data:`KEYS` (extra keys, such as a σ, are kept; a module
    breaking the interface fails loudly)."""
    for r in rows:
        if not set(KEYS) <= set(r):
            raise ValueError(f"{name}: a row has keys {sorted(r)}, the interface is {list(KEYS)}")
    return [dict(r) for r in rows]


def table(rows) -> str:
    from tendyn.results import format_table

    def f(v):
        return "-" if v is None else (f"{v:.5g}" if isinstance(v, float) else str(v))

    return format_table(("data set", "peer", "metric", "item", "peer", "tendyn preset", "tendyn default", "unit"),
                        [tuple(f(r[k]) for k in KEYS[:2]) + (r["metric"], f(r["item"])) +
                         tuple(f(r[k]) for k in KEYS[4:]) for r in rows],
                        title="real data: the peers' published numbers and tendyn's")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", default=None)
    ap.add_argument("--out", default=str(HERE.parents[1] / "build" / "realdata"))
    ap.add_argument("--json", default=str(HERE.parent / "realdata.json"))
    ap.add_argument("--only", default=None)
    args = ap.parse_args(argv)
    shared = shared_folder(args.shared)
    mods = dataset_modules()
    if args.only:
        mods = {k: v for k, v in mods.items() if k in args.only.split(",")}
    rows, info, sections = [], {}, []
    from tendyn.report import Section, Table, run_info, section_of, write_html_report

    for name, mod in mods.items():
        t0 = time.perf_counter()
        try:
            got = check_rows(name, mod.rows(shared))
        except FileNotFoundError as exc:
            info[name] = {"skipped": f"data absent: {exc}"}
            print(f"[realdata] {name}: skipped (data absent: {exc})", file=sys.stderr)
            continue
        info[name] = {"seconds": time.perf_counter() - t0, "skipped": None}
        rows += got
        sections.append(Section(f"{name}: against {', '.join(sorted({r['peer'] for r in got}))}",
                                getattr(mod, "__doc__", "") or "",
                                [Table(KEYS, [[r[k] for k in KEYS] for r in got], title=name)]))
        if hasattr(mod, "figures"):
            for title, res in mod.figures(shared):
                sections.append(section_of(f"{name}: {title}", res))
    doc = {"rows": rows, "datasets": info}
    Path(args.json).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    write_html_report(args.out, "tendyn on real robots: against the peers' published identifications",
                      run_info("realdata", options={"shared": str(shared)}), sections, data=doc,
                      json_name="realdata.json")
    print(table(rows))
    print(f"[realdata] {args.json}; page {Path(args.out) / 'report.html'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
