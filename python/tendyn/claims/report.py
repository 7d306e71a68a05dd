"""The claims' report: ``report.html``, ``claims.json`` and ``claims.txt`` into a folder, all files or none.

:func:`write_report` is the one function ``tendyn claims --report`` calls; the page is the project's HTML report
(:func:`tendyn.report.write_html_report`, docs/reports.md): one row per check, the failures as warnings."""

from __future__ import annotations

from pathlib import Path


def table(rows: list[dict]) -> str:
    """claim / paper value / tendyn value / band / status, one row per check; expected failures' reasons below."""
    head = ("claim", "paper value", "tendyn value", "band", "status")
    width = (12, 34, 48, 40, 8)

    def cut(text: str, n: int) -> str:
        text = " ".join(str(text).split())
        return text if len(text) <= n else text[: n - 1] + "…"

    lines = ["  ".join(h.ljust(w) for h, w in zip(head, width)).rstrip()]
    lines.append("  ".join("-" * w for w in width))
    for r in rows:
        cells = (r["claim"], r["paper_value"], r["tendyn_value"] or "—", r["band"], r["status"])
        lines.append("  ".join(cut(c, w).ljust(w) for c, w in zip(cells, width)).rstrip())
    notes = [r for r in rows if r["status"] in ("xfail", "XPASS", "FAILS", "ERROR", "skipped")]
    if notes:
        lines.append("")
    for r in notes:
        why = r["reason"] if r["status"] in ("xfail", "XPASS", "skipped") else "; ".join(r["failed_conditions"])
        lines.append(f"{r['claim']} {r['status']}: {why}")
    return "\n".join(lines)


def write_report(out: Path, doc: dict) -> list[Path]:
    """Write ``doc`` (the JSON of ``tendyn claims --json``) into the folder ``out`` as claims.json and claims.txt;
    returns the paths written."""
    from tendyn.io import atomic_write_text
    from tendyn.io.files import all_or_none

    from tendyn.report import HTML_NAME, Section, Table, run_info, write_html_report

    out = Path(out)
    rows = doc["claims"]
    bad = [f"{r['claim']} {r['status']}: " + ("; ".join(r["failed_conditions"]) or r["reason"] or "")
           for r in rows if r["status"] in ("FAILS", "ERROR", "XPASS")]
    section = Section("Claims", text=summary_line(doc), warnings=bad, tables=[Table(
        ("claim", "paper", "statement", "paper value", "tendyn value", "band", "status", "reason"),
        [(r["claim"], r["paper"], r["statement"], r["paper_value"], r["tendyn_value"] or "—", r["band"], r["status"],
          r["reason"] or "") for r in rows], title=f"{len(rows)} checks ({doc['mode']} mode)")])
    with all_or_none(out) as stage:
        atomic_write_text(stage / "claims.txt", table(rows) + "\n\n" + summary_line(doc) + "\n")
        write_html_report(stage, "tendyn claims: the papers' results today",
                          run_info("claims", options={"mode": doc["mode"]}), [section], data=doc,
                          json_name="claims.json", extra_files=["claims.txt"])
    return [out / "claims.json", out / "claims.txt", out / HTML_NAME]


def summary_line(doc: dict) -> str:
    c = doc["counts"]
    return (f"{c['holds']} hold, {c['xfail']} expected failures, {c['FAILS'] + c['ERROR']} failed, "
            f"{c['XPASS']} unexpectedly passing, {c['skipped']} skipped ({doc['mode']}, {doc['wall_s']:.0f} s)")
