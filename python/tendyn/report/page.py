"""One HTML page per run of a command: an index of what ran, warnings, tables and figures (SVG), the JSON beside.

The page is self-contained (figures are SVG embedded as data URIs, the style is inline, no script, nothing
fetched) and is written from the Jinja2 template ``templates/report.html.j2`` shipped with the package. Every
text on it is data (docs/security.md): escaped whatever it holds, and the page's Content-Security-Policy forbids
script and any load but its own data-URI figures and its one inline style block (by hash). This
module turns result objects into sections and sections into the page; it computes nothing (DESIGN: ``report/``).

Public API (stable: other commands, e.g. ``tendyn claims``, call it):

* :func:`write_html_report` ``(out_dir, title, run_info, sections, *, data=None, ...) -> Path``
* :func:`run_info` ``(command, *, device=None, logs=(), options=None) -> dict``
* :class:`Section`, :class:`Figure`, :class:`Table`, and :func:`section_of` (a section from a Result).
"""

from __future__ import annotations

import base64
import datetime as _dt
import hashlib
import io
import json
import os
import platform
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

from tendyn.report.checks import scan
from tendyn.report.tables import Table, Text, split_text

__all__ = ["Figure", "Section", "Table", "run_info", "section_of", "write_html_report", "HTML_NAME"]

HTML_NAME = "report.html"
"""File name of the page inside a report folder."""


@dataclass
class Figure:
    """A figure of a section: ``figure`` a matplotlib Figure or a :class:`tendyn.results.Result` (drawn with
    ``plot()``), ``caption`` one sentence on how to read it (default: the result's ``reading``), ``name`` the
    file stem of its PNG beside the page (when the caller asks for PNGs)."""

    figure: Any
    caption: str = ""
    name: str = ""

    def matplotlib(self):
        fig = self.figure
        return fig.plot() if hasattr(fig, "plot") and hasattr(fig, "to_dict") else fig

    def text(self) -> str:
        return self.caption or getattr(self.figure, "reading", "") or ""


@dataclass
class Section:
    """A part of the page: a title, a paragraph, tables (:class:`Table`, or the text of a ``Result.table()``,
    cut into HTML tables), figures (:class:`Figure`) and warnings (sentences)."""

    title: str
    text: str = ""
    tables: list = field(default_factory=list)
    figures: list = field(default_factory=list)
    warnings: list = field(default_factory=list)


def section_of(title: str, result, *, name: str = "", caption: str = "", text: str = "",
               figure: bool = True) -> Section:
    """A section from one result object: its ``table()``, its figure (``plot()``) and its ``warnings``, plus the
    implausible values of its ``to_dict()`` (:func:`tendyn.report.checks.scan`)."""
    warnings = list(getattr(result, "warnings", []) or [])
    try:
        warnings += [w for w in scan(_jsonable(result.to_dict())) if w not in warnings]
    except (AttributeError, NotImplementedError):
        pass
    figs = [Figure(result, caption, name or _slug(title))] if figure and hasattr(result, "plot") else []
    return Section(title, text, [result.table()] if hasattr(result, "table") else [], figs, warnings)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text.lower()).strip("_") or "figure"


def _jsonable(value):
    from tendyn.io import to_jsonable

    return to_jsonable(value)


def _sha256(path) -> str | None:
    try:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        return h.hexdigest()
    except OSError:
        return None


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tendyn")
    except PackageNotFoundError:
        return "unknown"


def run_info(command: str, *, device=None, logs: Iterable = (), options: Any = None) -> dict:
    """What ran: ``command`` (e.g. ``"identify"``), the device (name, file, SHA-256 of its file and URDF, and its
    routing drawn as SVG, ``routing_svg``, when it has cables), the
    logs (path, size [bytes], SHA-256), the options (an argparse Namespace or a dict; callables dropped), the
    tendyn version, a fresh run id and the date (UTC, ISO 8601)."""
    dev = None
    if device is not None:
        path = getattr(device, "path", None)
        digest = None
        if path is not None and Path(path).is_file():
            h = hashlib.sha256(Path(path).read_bytes())
            urdf = getattr(getattr(device, "kinematics", None), "urdf", None)
            if urdf is not None and Path(urdf).is_file():
                h.update(Path(urdf).read_bytes())
            digest = h.hexdigest()
        dev = {"name": getattr(device, "name", str(device)), "kind": getattr(device, "kind", None),
               "file": None if path is None else str(path), "sha256": digest}
    svg = _routing_drawing(device)
    opts = vars(options) if options is not None and hasattr(options, "__dict__") else dict(options or {})
    opts = {k: (str(v) if isinstance(v, os.PathLike) else v) for k, v in opts.items()
            if not callable(v) and k not in ("logs",)}
    log_rows = [{"path": str(p), "bytes": Path(p).stat().st_size if Path(p).is_file() else None,
                 "sha256": _sha256(p)} for p in logs]
    now = _dt.datetime.now(_dt.timezone.utc)
    return {"command": command, "tendyn_version": _version(), "python": platform.python_version(),
            "run_id": f"{now:%Y%m%dT%H%M%SZ}-{uuid.uuid4().hex[:8]}", "date": now.isoformat(timespec="seconds"),
            "device": dev, "logs": log_rows, "options": _jsonable(opts), "routing_svg": svg}


def _routing_drawing(device):
    """The device's routing drawn (:func:`tendyn.drawing.routing_svg`; its text escaped, no script), as markup the
    page embeds inline in its index; None without a device or without cables."""
    if device is None:
        return None
    from markupsafe import Markup

    from tendyn.drawing import routing_svg

    svg = routing_svg(device)
    return None if svg is None else Markup(svg)


def _svg_data_uri(fig) -> tuple[str, tuple[float, float]]:
    """The figure as SVG (text as paths: no font needed by the reader) in a data URI, and its size [in]."""
    buf = io.BytesIO()
    fig.savefig(buf, format="svg")
    size = tuple(float(v) for v in fig.get_size_inches())
    return "data:image/svg+xml;base64," + base64.b64encode(buf.getvalue()).decode("ascii"), size


def _env():
    """The page's template engine: every ``{{ … }}`` is HTML-escaped whatever the template's file name
    (``select_autoescape`` decides from the name, and ``report.html.j2`` does not end in ``.html``: issue 36); only
    what tendyn generates itself (the figures' data URIs) is marked safe, in :func:`render_html`."""
    from jinja2 import Environment, PackageLoader, StrictUndefined

    env = Environment(loader=PackageLoader("tendyn.report", "templates"), autoescape=True,
                      undefined=StrictUndefined, trim_blocks=True, lstrip_blocks=True)
    env.filters["csp_sha256"] = _csp_sha256
    return env


def _csp_sha256(text) -> str:
    """The Content-Security-Policy source of an inline block: ``'sha256-<base64 of its SHA-256>'``."""
    digest = hashlib.sha256(str(text).encode("utf-8")).digest()
    return f"'sha256-{base64.b64encode(digest).decode('ascii')}'"


def render_html(title: str, info: dict, sections: Sequence[Section], *, files: Sequence[str] = (),
                json_name: str | None = None, warnings: Sequence[str] = (), png_dpi: int | None = None,
                png_dir: Path | None = None) -> str:
    """The page as a string (see :func:`write_html_report`); with ``png_dir`` each figure is also saved there as
    ``NAME.png`` at ``png_dpi``."""
    from markupsafe import Markup

    from tendyn.io import save_png

    rendered = []
    for k, sec in enumerate(sections):
        blocks = []
        for t in sec.tables:
            blocks += split_text(t) if isinstance(t, str) else [t if isinstance(t, (Table, Text)) else Table(**t)]
        figs = []
        for f in sec.figures:
            fig = f.matplotlib()
            uri, (w, h) = _svg_data_uri(fig)
            figs.append({"uri": Markup(uri), "caption": f.text(), "name": f.name, "width_in": w, "height_in": h})
            if png_dir is not None and f.name:
                _freeze_layout(fig)    # the layout of the SVG, not computed again (seconds on log axes)
                save_png(fig, png_dir / f"{f.name}.png", **({"dpi": png_dpi} if png_dpi else {}))
            else:
                _close(fig)
        rendered.append({"id": f"s{k + 1}", "title": sec.title, "text": sec.text, "blocks": blocks,
                         "figures": figs, "warnings": list(sec.warnings)})
    return _env().get_template("report.html.j2").render(
        title=title, info=info, sections=rendered, files=list(files), json_name=json_name,
        warnings=list(warnings), options_json=json.dumps(info.get("options", {}), indent=1, sort_keys=True))


def _freeze_layout(fig) -> None:
    """Keep the axes where the last draw put them (constrained layout computed once per figure)."""
    try:
        fig.set_layout_engine("none")
    except (AttributeError, RuntimeError):     # older matplotlib, or an engine that cannot be swapped
        pass


def _close(fig) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)


def write_html_report(out_dir, title: str, run_info: dict, sections: Sequence[Section], *, data: Any = None,
                      json_name: str = "report.json", html_name: str = HTML_NAME, pngs: bool = False,
                      extra_files: Sequence[str] = ()) -> tuple[Path, list[str]]:
    """Write ``html_name`` (and ``data`` as ``json_name`` beside it, when given) into ``out_dir``.

    Parameters
    ----------
    out_dir : path-like
        Folder (created if needed). Each file is written atomically; to write a set of files all or none, pass
        the staging folder of :func:`tendyn.io.files.all_or_none`.
    title : str
        Heading of the page.
    run_info : dict
        What ran, from :func:`run_info` (any extra keys are shown too).
    sections : sequence of Section
    data : JSON-able, optional
        The command's JSON document, written as ``json_name`` and linked from the page; its implausible values
        (:func:`tendyn.report.checks.scan`) join the warnings.
    pngs : bool
        Also save each named figure as ``NAME.png`` beside the page.
    extra_files : sequence of str
        Other files of the folder to list in the index (relative names).

    Returns
    -------
    (Path, list of str)
        The page's path and every warning shown on it (callers print them on stderr).
    """
    from tendyn.io import atomic_write_text

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    warnings: list[str] = []
    for sec in sections:
        warnings += [w for w in sec.warnings if w not in warnings]
    files = list(extra_files)
    if data is not None:
        doc = _jsonable(data)
        warnings += [w for w in scan(doc) if w not in warnings]
        atomic_write_text(out / json_name, json.dumps(doc, indent=2) + "\n")
        files.insert(0, json_name)
    if pngs:
        files += [f"{f.name}.png" for s in sections for f in s.figures if f.name]
    html = render_html(title, run_info, sections, files=files, json_name=json_name if data is not None else None,
                       warnings=warnings, png_dir=out if pngs else None)
    path = atomic_write_text(out / html_name, html)
    return path, warnings
