"""`tendyn pipeline NAME [DEVICE] [--report DIR] [--json]`: one paper's workflow end to end.

Pipelines register themselves in :data:`PIPELINES` (name → :class:`Pipeline`) from their own command
module (``tendyn.commands.pipeline_s1`` registers ``s1``), so that several can be added independently; this
module owns the one ``pipeline`` subparser and dispatches its ``NAME`` positional to the registry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from tendyn.errors import UsageError


@dataclass(frozen=True)
class Pipeline:
    """A registered pipeline: ``run(args) -> int`` (parses nothing itself), its default device and help."""

    name: str
    run: Callable
    default_device: str
    help: str = ""


PIPELINES: dict[str, Pipeline] = {}


def register_pipeline(p: Pipeline) -> None:
    """Add a pipeline to the registry (idempotent for the same name)."""
    PIPELINES[p.name] = p


def _dispatch(args) -> int:
    _load_pipeline_modules()
    p = PIPELINES.get(args.name)
    if p is None:
        raise UsageError(f"unknown pipeline {args.name!r} (known: {', '.join(sorted(PIPELINES)) or 'none'})", "name")
    if args.device is None:
        args.device = p.default_device
    if args.report is not None:                 # before the work: a file or an unwritable place is exit 2
        from tendyn.cli import _check_out_folder

        _check_out_folder(args.report, "report")
    try:
        return p.run(args)
    finally:
        global _TICKER
        if _TICKER is not None:
            _TICKER.close()
            _TICKER = None


def _load_pipeline_modules() -> None:
    import importlib
    import pkgutil

    import tendyn.commands as commands

    for info in pkgutil.iter_modules(commands.__path__):
        if info.name.startswith("pipeline_"):
            importlib.import_module(f"tendyn.commands.{info.name}")


def register(subparsers) -> None:
    if "pipeline" in getattr(subparsers, "choices", {}):
        return
    _load_pipeline_modules()
    names = ", ".join(f"{k} ({v.help})" for k, v in sorted(PIPELINES.items()))
    p = subparsers.add_parser("pipeline", help="run one paper's workflow end to end", epilog=f"pipelines: {names}")
    p.add_argument("name", metavar="NAME", help=f"pipeline name: {', '.join(sorted(PIPELINES))}")
    p.add_argument("device", nargs="?", default=None, help="device file or bundled twin [default: the pipeline's]")
    p.add_argument("--report", default=None, metavar="DIR", help="write figures (PNG) and data (JSON) into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.add_argument("--quick", action="store_true", help="coarser grids and shorter runs (tests)")
    p.set_defaults(func=_dispatch)


def publish(args, doc: dict, table: str, figures: dict, out, json_name: str, text_name: str | None = None) -> int:
    """Write a command's report into ``out`` (figures as PNG, ``doc`` as ``json_name``, the table as ``text_name``;
    all files or none) when ``out`` is given, then print ``doc`` (``--json``) or the table. Returns 0.

    ``figures``: name → a :class:`tendyn.results.Result` (``NAME.png``)."""
    import json

    from tendyn.cli import _print_json
    from tendyn.io import atomic_write_text, save_png, to_jsonable
    from tendyn.io.files import all_or_none

    if out is not None:
        with all_or_none(out) as stage:
            for name, res in figures.items():
                save_png(res.plot(), stage / f"{name}.png")
            atomic_write_text(stage / json_name, json.dumps(to_jsonable(doc), indent=2) + "\n")
            if text_name:
                atomic_write_text(stage / text_name, table + "\n")
        doc["report"] = str(out)
    if args.json:
        _print_json(doc)
    else:
        print(table)
        if out is not None:
            print(f"report: {out}")
    return 0


def say(msg: str) -> None:
    """Progress on stderr: a bar with the step and elapsed time on a terminal, step lines otherwise
    (:class:`tendyn.progress.Ticker`)."""
    global _TICKER
    from tendyn.progress import Ticker

    if _TICKER is None:
        _TICKER = Ticker("pipeline")
    _TICKER(msg)


_TICKER = None
