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
    """A registered pipeline: ``run(args) -> int`` (parses nothing itself), its default device and help;
    ``writes_logs``: it accepts ``--logs DIR`` (writes the logs it used there)."""

    name: str
    run: Callable
    default_device: str
    help: str = ""
    writes_logs: bool = False


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
    if getattr(args, "logs", None) is not None and not p.writes_logs:
        known = ", ".join(sorted(k for k, v in PIPELINES.items() if v.writes_logs)) or "none"
        raise UsageError(f"pipeline {p.name} writes no logs (--logs: {known})", "logs")
    from tendyn.commands.shared import check_out_folder as _check_out_folder

    if args.report is not None:                 # before the work: a file or an unwritable place is exit 2
        _check_out_folder(args.report, "report")
    if getattr(args, "logs", None) is not None:
        _check_out_folder(args.logs, "logs")
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
    p.add_argument("--report", default=None, metavar="DIR", help="write report.html (figures, tables, warnings), the data (JSON) and PNGs into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.add_argument("--logs", default=None, metavar="DIR",
                   help="write every log the pipeline used (with its truth sidecar and index.json) into DIR "
                        f"[pipelines: {', '.join(sorted(k for k, v in PIPELINES.items() if v.writes_logs))}]")
    p.add_argument("--quick", action="store_true", help="coarser grids and shorter runs (tests)")
    p.set_defaults(func=_dispatch)


def publish(args, doc: dict, table: str, figures: dict, out, json_name: str, text_name: str | None = None,
            **kw) -> int:
    """:func:`tendyn.report.publish` (the one path of every ``--report``), for ``tendyn pipeline NAME``."""
    from tendyn.report import publish as _publish

    kw.setdefault("command", f"pipeline {getattr(args, 'name', '')}".strip())
    return _publish(args, doc, table, figures, out, json_name, text_name, **kw)


def say(msg: str) -> None:
    """Progress on stderr: a bar with the step and elapsed time on a terminal, step lines otherwise
    (:class:`tendyn.progress.Ticker`)."""
    global _TICKER
    from tendyn.progress import Ticker

    if _TICKER is None:
        _TICKER = Ticker("pipeline")
    _TICKER(msg)


_TICKER = None
