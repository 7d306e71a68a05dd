"""HTML reports (docs/reports.md, issue 20 items 1–3): every command that writes a report is run once on a small
device; each page is opened in headless Chromium (no console error, every figure drawn with a size, tables
present, a screenshot kept), and every figure each command draws is walked for axis labels with units and for
legends.

The artefacts (reports and screenshots) go to a temporary folder of the test process (printed at the end of
the run), or to ``$TENDYN_TEST_ARTEFACTS/test-reports/`` when that variable is set: a reader can open them. The browser is Debian's ``chromium`` (installed with apt by ``make tools`` or
here when missing and root); the browser tests skip, saying why, only where it cannot be installed.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from browser import Browser, find_chromium

REPO = Path(__file__).resolve().parents[2]
TX40_DATA = REPO / "python" / "tendyn" / "data" / "tx40"

UNIT = re.compile(r"\[[^\]]+\]|\([^)]*\)")
"""A unit in brackets (``[N·m]``) or parentheses (``(Hz)``)."""


# ---- running the commands, collecting the figures they draw --------------------------------------------------

def _commands(work: Path) -> dict:
    """name → (argv list, report page). Small devices and grids: seconds each."""
    from tendyn.analysis.operational import true_params
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.devices.generate import write_cable_device

    from datetime import datetime, timedelta, timezone

    from tendyn.ident import history as hist

    gen = write_cable_device(work, 3, seed=4)
    db, lexos = work / "history.sqlite", load_device(bundled("lexos"))
    for day, c in enumerate((0.05, 0.05, 0.07)):       # the third record drifts
        hist.record(lexos, "identify-friction", {"fits": [{"transmission": 1, "coulomb_motor": c,
                                                           "coulomb_motor_std": 0.002, "viscous_motor": 1e-3,
                                                           "viscous_motor_std": 1e-4}]},
                    db=db, created=datetime(2026, 3, 1, tzinfo=timezone.utc) + timedelta(days=day))
    cea = work / "cea_params.json"
    cea.write_text(json.dumps({"params": true_params(load_device(bundled("cea_branch")))}), encoding="utf-8")
    log = work / "tx40.parquet"
    r = lambda name: work / name  # noqa: E731
    return {
        "log_import": (["log", "import", str(TX40_DATA / "pos_read_data.csv"), str(TX40_DATA / "curr_data.csv"),
                        "--map", str(TX40_DATA / "import.toml"), "--out", str(log)], None),
        "identify_tx40": (["identify", "tx40", str(log), "--out", str(work / "tx40_params.json"), "--quiet",
                           "--report", str(r("identify_tx40"))], r("identify_tx40") / "report.html"),
        "identify_stream_tx40": (["identify", "tx40", str(log), "--stream", "--report", str(r("identify_stream"))],
                                 r("identify_stream") / "report.html"),
        "validate_tx40": (["validate", "tx40", str(work / "tx40_params.json"), str(log), "--report",
                           str(r("validate_tx40"))], r("validate_tx40") / "report.html"),
        "maps_generated": (["maps", str(gen), "--points", "3", "--report", str(r("maps_generated"))],
                           r("maps_generated") / "report.html"),
        "maps_cea_branch": (["maps", "cea_branch", str(cea), "--points", "3", "--half-width", "0.02", "--report",
                             str(r("maps_cea_branch"))], r("maps_cea_branch") / "report.html"),
        "pipeline_s0": (["pipeline", "s0", "--quick", "--report", str(r("pipeline_s0"))],
                        r("pipeline_s0") / "report.html"),
        "pipeline_s1": (["pipeline", "s1", "--quick", "--report", str(r("pipeline_s1"))],
                        r("pipeline_s1") / "report.html"),
        "pipeline_s2": (["pipeline", "s2", "--quick", "--report", str(r("pipeline_s2"))],
                        r("pipeline_s2") / "report.html"),
        "sweep": (["sweep", "mcgill_bench", "--param", "k1=20000:400000:2", "--amplitudes", "0.6,2", "--workers", "1",
                   "--quiet", "--out", str(work / "sweep.parquet")], work / "sweep.html"),
        "simulate_prbs": (["simulate", "mcgill_bench", "prbs", "--torque", "1", "--duration", "4", "--quiet",
                           "--out", str(work / "prbs.csv")], None),
        "frf": (["frf", str(work / "prbs.csv"), "--segment", "1000", "--report", str(r("frf"))], r("frf") / "report.html"),
        "identify_bench": (["identify-bench", str(work / "prbs.csv"), "--structure", "wiener", "--nonlinearity",
                            "dead-zone", "--order", "2", "--shift", "1", "--validate", str(work / "prbs.csv"),
                            "--report", str(r("identify_bench"))], r("identify_bench") / "report.html"),
        "zwidth": (["zwidth", "lexos", "--stiffness", "1000:100000:2", "--damping", "0:0:1", "--modes", "compensated",
                    "--scheduler", "none", "--quiet", "--out", str(work / "zwidth.parquet")], work / "zwidth.html"),
        "history": (["history", "lexos", "--db", str(db), "--report", str(r("history"))], r("history") / "report.html"),
        "claims": (["claims", "--quick", "--only", "C1,C2", "--quiet", "--report", str(r("claims"))],
                   r("claims") / "report.html"),
        "demo_lexos": (["demo", "lexos", "--out", str(r("demo_lexos"))], r("demo_lexos") / "report.html"),
        "demo_generated": (["demo", str(gen), "--out", str(r("demo_generated"))], r("demo_generated") / "report.html"),
        "demo_mcgill_bench": (["demo", "mcgill_bench", "--out", str(r("demo_mcgill_bench"))],
                              r("demo_mcgill_bench") / "report.html"),
        "demo_cea_branch": (["demo", "cea_branch", "--out", str(r("demo_cea_branch"))],
                            r("demo_cea_branch") / "report.html"),
    }


@pytest.fixture(scope="module")
def artefacts(tmp_path_factory) -> Path:
    """Where this module's reports and screenshots go: ``$TENDYN_TEST_ARTEFACTS/test-reports`` when that is set
    (to look at them afterwards), else a temporary folder of this test process (parallel workers never share it,
    and nothing is written inside the source tree)."""
    keep = os.environ.get("TENDYN_TEST_ARTEFACTS")
    if keep:
        out = Path(keep) / "test-reports"
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True)
        return out
    return tmp_path_factory.mktemp("test-reports")


@pytest.fixture(scope="module")
def runs(s0_quick_run, s1_quick_report, s2_quick_report, artefacts):
    """Run every command once: {name: {"page": Path, "figures": [Figure], "stderr": str}}."""
    import io
    import sys
    import time
    from contextlib import redirect_stderr, redirect_stdout

    from matplotlib.figure import Figure

    from tendyn.cli import main

    drawn: list = []
    original = Figure.savefig

    def recording(self, *a, **kw):
        if kw.get("format") == "svg":      # the page's copy: each figure once
            drawn.append(self)
        return original(self, *a, **kw)

    import tendyn.pipelines.s0
    import tendyn.pipelines.s1
    import tendyn.pipelines.s2

    out = {}
    mp = pytest.MonkeyPatch()      # the pipelines: the session's quick runs (conftest.py), published here
    mp.setattr(tendyn.pipelines.s0, "run_s0", s0_quick_run)
    mp.setattr(tendyn.pipelines.s1, "run_s1", lambda dev, quick=False, progress=None: s1_quick_report)
    mp.setattr(tendyn.pipelines.s2, "run_s2", lambda dev, quick=False, progress=None: s2_quick_report)
    Figure.savefig = recording
    try:
        for name, (argv, page) in _commands(artefacts).items():
            drawn.clear()
            err = io.StringIO()
            t0 = time.perf_counter()
            with redirect_stdout(io.StringIO()), redirect_stderr(err):
                code = main(argv)
            print(f"[test_reports] {name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
            assert code == 0, f"{name}: exit {code}: {err.getvalue()}"
            if page is not None:
                out[name] = {"page": page, "figures": list(drawn), "stderr": err.getvalue()}
    finally:
        Figure.savefig = original
        mp.undo()
    print(f"\n[test_reports] reports and screenshots: {artefacts}", file=sys.stderr)
    return out


# ---- figures: labels, units, legends ----------------------------------------------------------------------------

def figure_problems(fig) -> list[str]:
    """What a reader cannot read on a figure: an axis without a label or without a unit, several labelled curves
    without a legend."""
    problems = []
    for k, ax in enumerate(fig.axes):
        if not ax.get_visible() or not ax.axison:
            continue
        where = f"axes {k} ({ax.get_title() or fig.axes[0].get_title() or 'untitled'})"
        colorbar = getattr(ax, "_colorbar", None)
        if colorbar is not None:
            label = ax.get_ylabel() or ax.get_xlabel()
            if not UNIT.search(label):
                problems.append(f"{where}: colour bar label {label!r} without a unit")
            continue
        if not (ax.lines or ax.collections or ax.patches or ax.images):
            continue
        for axis in ("x", "y"):
            label = getattr(ax, f"get_{axis}label")()
            shared = getattr(ax, f"get_shared_{axis}_axes")().get_siblings(ax)
            if not label:     # stacked panels: the label of a sibling sharing this axis counts
                label = next((getattr(s, f"get_{axis}label")() for s in shared if getattr(s, f"get_{axis}label")()),
                             "")
            if not label:
                problems.append(f"{where}: no {axis} label")
            elif not UNIT.search(label):
                problems.append(f"{where}: {axis} label {label!r} has no unit in [ ] or ( )")
        labelled = [a for a in list(ax.lines) + list(ax.collections) + list(ax.patches)
                    if a.get_label() and not a.get_label().startswith("_")]
        names = {a.get_label() for a in labelled}
        legends = [lg for a in fig.axes if (lg := a.get_legend()) is not None] + list(fig.legends)
        told = {t.get_text() for lg in legends for t in lg.get_texts()}   # panels of the same curves share one
        if len(names) > 1 and ax.get_legend() is None and not names <= told:
            problems.append(f"{where}: {len(names)} labelled curves ({', '.join(sorted(names)[:4])}) and no legend")
    return problems


def test_every_figure_of_every_command_has_labels_units_and_legends(runs):
    """Issue 20 item 3: each Axes of each figure a command draws has an x and a y label with a unit, and a legend
    when it has more than one labelled curve."""
    bad = {}
    for name, run in runs.items():
        assert run["figures"] or name == "claims", f"{name} drew no figure"
        for fig in run["figures"]:
            p = figure_problems(fig)
            if p:
                bad.setdefault(name, []).extend(p)
    assert not bad, "\n".join(f"{n}: {p}" for n, ps in bad.items() for p in ps)


def test_figure_check_can_fail():
    """The walker itself: a figure without a unit, or with two unlabelled-legend curves, is caught."""
    from tendyn.results import new_figure

    fig, ax = new_figure()
    ax.plot([0, 1], [0, 1], label="a")
    ax.plot([0, 1], [1, 0], label="b")
    ax.set_xlabel("time")
    ax.set_ylabel("torque [N·m]")
    p = figure_problems(fig)
    assert any("x label 'time'" in s for s in p) and any("no legend" in s for s in p), p
    ax.set_xlabel("time [s]")
    ax.legend()
    assert figure_problems(fig) == []


def test_identify_draws_one_panel_per_joint(runs):
    """The identify figure: one Axes per joint of the TX40 (six), not six joints overlaid on one."""
    figs = runs["identify_tx40"]["figures"]
    assert len(figs) == 1 and len([a for a in figs[0].axes if a.lines]) == 6


def test_maps_compare_with_s2_only_on_s2s_twin(runs, tmp_path):
    """The maps table has the paper's column on cea_branch (S2's twin) and none on another device; a copy of the
    twin edited by hand is another device (tendyn.devices.is_twin_of)."""
    from tendyn.device import load_device
    from tendyn.devices import bundled, is_twin_of

    cea = (runs["maps_cea_branch"]["page"].parent / "maps.txt").read_text()
    gen = (runs["maps_generated"]["page"].parent / "maps.txt").read_text()
    assert "S2 (paper)" in cea and "S2" not in gen.replace("S2 eq", "")
    twin = load_device(bundled("cea_branch"))
    edited = tmp_path / "branch.toml"
    edited.write_text(bundled("cea_branch").read_text().replace('name = "CEA branch"', 'name = "my branch"', 1))
    assert is_twin_of(twin, "cea_branch") and not is_twin_of(twin, "lexos")
    assert not is_twin_of(load_device(edited), "cea_branch")


# ---- the pages in a browser --------------------------------------------------------------------------------------

PROBE = """(() => {
  const figs = [...document.querySelectorAll('img.figure')].map(i => {
    const r = i.getBoundingClientRect();
    return {w: r.width, h: r.height, nw: i.naturalWidth, nh: i.naturalHeight, ok: i.complete,
            caption: (i.parentElement.querySelector('figcaption') || {}).textContent || ''};
  });
  return {figures: figs, tables: document.querySelectorAll('table.data').length,
          cells: document.querySelectorAll('table.data td').length,
          index: !!document.querySelector('table.index'), scripts: document.scripts.length,
          external: [...document.querySelectorAll('[src],[href]')].map(e => e.getAttribute('src') || e.getAttribute('href'))
                     .filter(u => /^(https?:)?\\/\\//.test(u))};
})()"""


@pytest.fixture(scope="module")
def browser():
    exe, why = find_chromium()
    if exe is None:
        pytest.skip(f"no headless Chromium: {why}")
    b = Browser(exe)
    yield b
    b.close()


@pytest.fixture(scope="module")
def pages(runs, browser, artefacts):
    """Each report opened once in the one browser session: {name: what the page showed}."""
    shots = artefacts / "screenshots"
    shots.mkdir(exist_ok=True)
    return {name: browser.open(run["page"], shots / f"{name}.png", PROBE) | {"n_figures": len(run["figures"])}
            for name, run in runs.items()}


def test_every_report_opens_in_chromium_with_figures_and_tables(pages, artefacts):
    """Issue 20 items 1–2: no console error, every figure decoded and laid out with a non-zero size and a caption
    on how to read it, data tables with cells, the index, no script and nothing fetched from the network, and a
    screenshot of each page (the artefacts' screenshots/)."""
    for name, page in pages.items():
        probe = page["probe"]
        assert page["errors"] == [], f"{name}: {page['errors']}"
        assert len(probe["figures"]) == page["n_figures"] > (-1 if name == "claims" else 0), f"{name}: {probe}"
        for f in probe["figures"]:
            assert f["ok"] and f["nw"] > 0 and f["nh"] > 0 and f["w"] > 50 and f["h"] > 50, f"{name}: {f}"
            assert len(f["caption"].split()) >= 6, f"{name}: figure without a sentence on how to read it: {f}"
        assert probe["tables"] >= 1 and probe["cells"] > 0 and probe["index"], f"{name}: {probe}"
        assert probe["scripts"] == 0 and probe["external"] == [], f"{name}: {probe}"
        assert (artefacts / "screenshots" / f"{name}.png").stat().st_size > 10_000


def test_browser_sees_a_broken_figure_and_a_console_error(browser, tmp_path):
    """The browser check can fail: an image that does not decode has no natural size; a script error is seen."""
    page = tmp_path / "bad.html"
    page.write_text('<html><body><img class="figure" src="data:image/svg+xml;base64,bm90IGFuIHN2Zw==">'
                    '<script>console.error("broken")</script></body></html>', encoding="utf-8")
    seen = browser.open(page, None, PROBE)
    assert seen["errors"] and seen["probe"]["figures"][0]["nw"] == 0


# ---- the page's content ------------------------------------------------------------------------------------------

def test_report_index_names_device_hash_logs_version_and_json(runs, artefacts):
    """The index says what ran: device and its SHA-256, logs with theirs, options, version, run id, date; the
    JSON document lies beside the page and is linked from it."""
    import hashlib

    from tendyn.devices import bundled

    page = runs["identify_tx40"]["page"].read_text(encoding="utf-8")
    digest = hashlib.sha256(bundled("tx40").read_bytes())
    urdf = bundled("tx40").with_suffix(".urdf")
    digest.update(urdf.read_bytes())
    assert digest.hexdigest() in page
    assert hashlib.sha256((artefacts / "tx40.parquet").read_bytes()).hexdigest() in page
    for text in ("tendyn identify", "run id", "tendyn version", "date (UTC)", 'href="params.json"', "--quiet"
                 if False else "quiet"):
        assert text in page, text
    assert json.loads((runs["identify_tx40"]["page"].parent / "params.json").read_text())["device"] == "tx40"


def test_sweep_flags_peaks_at_the_grid_edge_on_stderr_and_in_the_report(runs):
    """A sweep whose peaks sit on the last frequency of its grid says so (issue 20: 236.9 dB and 40 Hz peaks
    printed without a word)."""
    from tendyn.pipelines.sweep import SweepResult

    res = SweepResult("bench", {"k1": [1.0, 2.0]}, [{"k1": 1.0, "peak_hz_2N": 40.0, "closed_loop_spread_db": 236.9},
                                                    {"k1": 2.0, "peak_hz_2N": 20.0, "closed_loop_spread_db": 3.0}],
                      "closed_loop_spread_db", freqs_hz=[8.0, 20.0, 40.0])
    w = res.warnings
    assert any("peak_hz_2N: 1 of 2 designs peak at 40 Hz" in s for s in w), w
    assert any("236.9 dB" in s for s in w), w
    assert SweepResult("bench", {"k1": [1.0]}, [{"k1": 1.0, "peak_hz_2N": 20.0}], "peak_shift_hz",
                       freqs_hz=[8.0, 20.0, 40.0]).warnings == []
    run = runs["sweep"]             # k1 = 4e5 N/m: the resonance lies above the 40 Hz end of the grid
    page = run["page"].read_text(encoding="utf-8")
    warnings = json.loads(run["page"].with_suffix(".json").read_text())["warnings"]
    assert any("peak at 40 Hz, the highest frequency of the grid" in s for s in warnings), warnings
    for s in warnings:
        assert s in page and f"tendyn sweep: warning: {s}" in run["stderr"]


def test_implausible_values_are_flagged():
    """Negative friction or inertia, %σ > 100, an efficiency beyond 1: each one warning; plausible ones none."""
    from tendyn.report.checks import scan

    doc = {"params": [{"name": "FV1", "value": 0.1, "rel_stderr_pct": 250.0},
                      {"name": "ZZ1", "value": 1.0, "rel_stderr_pct": 3.0}],
           "viscous_motor": [0.01, -0.002], "mass_load": 0.2, "reducer_efficiency": 1.3,
           "offset_error": -5.0, "coulomb_shift_N": -1.0, "dry_friction_max_direction": [-0.2, 0.9]}
    w = scan(doc)
    assert len(w) == 3, w
    assert any("FV1" in s and "250 %" in s for s in w) and any("viscous_motor" in s for s in w)
    assert any("reducer_efficiency" in s for s in w)
    assert scan({"viscous_motor": [0.01], "params": [{"name": "a", "rel_stderr_pct": 99.0}]}) == []


def test_write_html_report_api(tmp_path):
    """The stable API other commands (``tendyn claims``) call: sections of plain tables, the JSON beside."""
    from tendyn.report import Section, Table, run_info, write_html_report

    sec = Section("Claims", text="one row per claim", tables=[Table(["claim", "value [N]"], [["C1", 0.5]], "t")],
                  warnings=["C7 failed"])
    path, warnings = write_html_report(tmp_path / "r", "Claims", run_info("claims", options={"quick": True}),
                                       [sec], data={"claims": [{"id": "C1"}], "viscous": -1.0},
                                       json_name="claims.json")
    html = path.read_text(encoding="utf-8")
    assert path.name == "report.html" and (tmp_path / "r" / "claims.json").is_file()
    assert "<td>C1</td>" in html and "C7 failed" in html and "viscous = -1 is negative" in html
    assert warnings[0] == "C7 failed" and len(warnings) == 2
    assert "<script" not in html and "http://" not in html and "https://" not in html


def test_text_tables_become_html_tables():
    """A ``Result.table()`` text (format_table) is cut into cells along its rule; other lines stay text."""
    from tendyn.report.tables import Table, Text, split_text
    from tendyn.results import format_table

    text = format_table(("a", "value [N]"), [("x", 1.5), ("long name", -2.25)], "title") + "\nnote\n\n" + \
        format_table(("b",), [(1,)])
    blocks = split_text(text)
    assert [type(b) for b in blocks] == [Table, Text, Table]
    assert blocks[0].title == "title" and blocks[0].headers == ["a", "value [N]"]
    assert blocks[0].rows == [["x", "1.5"], ["long name", "-2.25"]] and blocks[1].text == "note"


def test_s2_tables_compare_with_the_paper_only_on_its_twin(s2_quick_report):
    """Pipeline s2 on S2's twin prints S2's Table 3 and Table 4 values beside its own; on another capstan device
    (``paper_twin`` false) the same tables come without the paper's columns."""
    import copy

    from tendyn.pipelines.s2 import S2Report

    s = s2_quick_report.summary
    assert s["paper_twin"] is True
    assert "S2 %σ" in s2_quick_report.table() and "S2 value" in s["friction_table"]
    other = S2Report(dict(s, paper_twin=False), s2_quick_report.figures).table()
    assert "S2 %σ" not in other and "within 3σ" not in other and "identified" in other
    fp = copy.copy(s2_quick_report.figures["friction"])
    fp.paper = False
    assert "S2 value" not in fp.table() and "Rel. dev. %" in fp.table()
