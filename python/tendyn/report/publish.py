"""The one path of every command's report (``--report DIR``; sweep and demo beside their outputs).

:func:`publish` writes, all files or none (:func:`tendyn.io.files.all_or_none`): ``report.html`` (the page of
:func:`tendyn.report.write_html_report`), the command's JSON document, the printed table as text, and one PNG per
figure; then it prints the JSON document (``--json``) or the table, and every warning on stderr (with or
without a report).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from tendyn.report.checks import scan
from tendyn.report.page import HTML_NAME, Figure, Section, run_info, section_of, write_html_report

__all__ = ["publish", "warn", "sections_of", "write_report", "write_beside"]


def warn(command: str, warnings: Sequence[str]) -> None:
    """Each warning as one line ``tendyn COMMAND: warning: …`` on stderr (control characters shown as escapes:
    :func:`tendyn.text.printable`)."""
    from tendyn.text import printable

    for w in warnings:
        print(printable(f"tendyn {command}: warning: {w}", keep=""), file=sys.stderr)


def sections_of(table: str, figures: Mapping[str, Any], summary: str = "Summary") -> list[Section]:
    """A summary section (the printed ``table``) and one section per figure (name → Result or Figure)."""
    out = [Section(summary, tables=[table])] if table else []
    for name, res in figures.items():
        if res is None:
            continue
        if isinstance(res, Figure):
            out.append(Section(name.replace("_", " "), figures=[res]))
        else:
            sec = section_of(name.replace("_", " "), res, name=name)
            sec.tables = [t for t in sec.tables if t != table]      # the summary shows it already
            out.append(sec)
    return out


def write_report(out, command: str, args, doc: dict | None, json_name: str, sections: Sequence[Section], *,
                 texts: Mapping[str, str] | None = None, device=None, logs: Sequence = (), title: str = "") -> Path:
    """Write ``report.html``, ``doc`` as ``json_name``, each ``texts`` item (file name → text) and a PNG per named
    figure into the folder ``out``, all or none. Returns the page's path."""
    from tendyn.io import atomic_write_text
    from tendyn.io.files import all_or_none

    out = Path(out)
    info = run_info(command, device=device, logs=logs, options=args)
    with all_or_none(out) as stage:
        for name, text in (texts or {}).items():
            atomic_write_text(stage / name, text + "\n")
        write_html_report(stage, title or f"tendyn {command}", info, sections, data=doc, json_name=json_name,
                          pngs=True, extra_files=list(texts or {}))
    return out / HTML_NAME


def publish(args, doc: dict, table: str, figures: Mapping[str, Any], out, json_name: str,
            text_name: str | None = None, *, command: str, device=None, logs: Sequence = (), title: str = "",
            sections: Sequence[Section] | None = None, quiet_table: bool = False) -> int:
    """Write a command's report into ``out`` (None: no report) and print its result. Returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The options (``args.json``: print ``doc`` as JSON instead of ``table``); shown in the report's index.
    doc : dict
        The command's JSON document (``json_name`` in the report; gains ``"report"``: the page's path).
    table : str
        The printed table (``text_name`` in the report when given).
    figures : mapping
        name → :class:`tendyn.results.Result` (a section each: its figure, table and warnings; ``NAME.png``).
    command : str
        The command as typed after ``tendyn`` (``"pipeline s1"``), for the index and the warning lines.
    device, logs : the device object and the log paths, for the index (name, file, SHA-256).
    sections : sequence of Section, optional
        The page's sections instead of :func:`sections_of` (``table``, ``figures``).
    quiet_table : bool
        Do not print the table (the caller prints its own lines).
    """
    import json

    from tendyn.io import to_jsonable

    secs = list(sections) if sections is not None else sections_of(table, figures)
    warnings: list[str] = []
    for s in secs:
        warnings += [w for w in s.warnings if w not in warnings]
    warnings += [w for w in scan(to_jsonable(doc)) if w not in warnings]
    if out is not None:
        out = Path(out)
        write_report(out, command, args, doc, json_name, secs, texts={text_name: table} if text_name else {},
                     device=device, logs=logs, title=title)
        doc["report"] = str(out / HTML_NAME)
    if args.json:
        print(json.dumps(to_jsonable(doc), indent=2))
    else:
        from tendyn.text import printable

        if not quiet_table:
            print(printable(table))
        if out is not None:
            print(printable(f"report: {out / HTML_NAME}"))
    sys.stdout.flush()
    warn(command, warnings)
    return 0


def write_beside(result, doc: dict, args, device, out, command: str, title: str, text: str = "") -> dict:
    """A grid command's outputs beside its table ``out`` (``.parquet``), all or none: the rows as Parquet, the
    figure (same stem, ``.png``), the page (``.html``) and ``doc`` (``.json``). ``result`` has ``rows``,
    ``plot``, ``table`` and ``warnings``. Returns ``doc`` with the paths of the table, figure and page."""
    from tendyn.io.files import all_or_none, atomic_write_rows

    out = Path(out)
    paths = {"table": str(out), "figure": str(out.with_suffix(".png")), "report": str(out.with_suffix(".html"))}
    doc = doc | paths
    with all_or_none(out.parent) as stage:
        atomic_write_rows(stage / out.name, result.rows)
        sections = [Section(title, text=text, tables=[result.table()], figures=[Figure(result, name=out.stem)],
                            warnings=list(getattr(result, "warnings", []) or []))]
        write_html_report(stage, title, run_info(command, device=device, options=args), sections, data=doc,
                          json_name=out.with_suffix(".json").name, html_name=out.with_suffix(".html").name,
                          pngs=True, extra_files=[out.name])
    return doc
