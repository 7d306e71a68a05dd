"""Text from a file is data on a page (issue 36 item 2): a device handed over by someone else, whose every text
field carries markup, read from a folder whose name carries markup, run with option values and log column names
that carry markup, through every command that writes a page; headless Chromium opens each page and nothing of
the input may have become a script, an element or an ``on…`` attribute: the hostile text is shown as text.

The payloads call ``console.error`` (seen by the browser driver), and the Content-Security-Policy the pages carry
reports a blocked script as a console error too: a page passes only when nothing of the input was parsed as HTML.
Term names cannot carry markup (letters, digits and _ only, refused at load: test_term_name_with_markup_is_refused).
"""

from __future__ import annotations

import io
import json
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from browser import Browser, find_chromium

REPO = Path(__file__).resolve().parents[2]

HOSTILE = ('<script>console.error("xss-script")</script><img src=x onerror="console.error(\'xss-img\')">'
           '<b data-hostile=1 onclick="console.error(1)">&amp;')
"""Markup in every text field of the device (each one gets a different suffix: names are unique)."""

FOLDER = "<img src=x onerror=console.error(7) data-hostile=1>&lt;"
"""Markup in the name of the folder the files are read from and written to (no slash: a folder name)."""

COLUMN = "<img src=x onerror=console.error(5) data-hostile=1>force"
"""Markup in a log column name (no comma: a CSV header cell), passed as an option value (--input)."""

PROBE = """(() => {
  const all = [...document.querySelectorAll('*')];
  return {
    scripts: document.scripts.length,
    injected: all.filter(e => e.hasAttribute('data-hostile') || [...e.attributes].some(a => /^on/i.test(a.name)))
                 .map(e => e.outerHTML.slice(0, 120)),
    b: document.querySelectorAll('b').length,
    stray_images: document.querySelectorAll('img:not(.figure)').length,
    text: document.body.innerText,
    title: document.title,
    csp: (document.querySelector('meta[http-equiv="Content-Security-Policy"]') || {}).content || null,
  };
})()"""


def _toml_str(text: str) -> str:
    return json.dumps(text)        # a JSON string is a TOML basic string for these characters


def hostile_cable_device(folder: Path) -> Path:
    """A generated 2-joint cable device whose device, joint and transmission names and description carry markup."""
    from tendyn.devices.generate import cable_device_toml

    text = cable_device_toml(2, seed=3)
    text = re.sub(r'^(name|description) = "([^"]*)"', lambda m: f"{m[1]} = {_toml_str(HOSTILE + ' ' + m[2])}",
                  text, flags=re.M)
    path = folder / "hostile.toml"
    path.write_text(text, encoding="utf-8")
    return path


def hostile_geared_device(folder: Path) -> Path:
    """The TX40's file (geared motors) with a hostile device name, description and motor (actuator) names."""
    from tendyn.devices import bundled

    src = bundled("tx40")
    text = src.read_text(encoding="utf-8")
    text = re.sub(r'^(name|description) = "([^"]*)"', lambda m: f"{m[1]} = {_toml_str(HOSTILE + ' ' + m[2])}",
                  text, flags=re.M)
    text = re.sub(r"^joint = (\d+)$", lambda m: f"name = {_toml_str(HOSTILE + ' motor' + m[1])}\n{m[0]}", text,
                  flags=re.M)
    (folder / src.with_suffix(".urdf").name).write_bytes(src.with_suffix(".urdf").read_bytes())
    path = folder / "hostile_geared.toml"
    path.write_text(text, encoding="utf-8")
    return path


def hostile_bench(folder: Path) -> Path:
    """The McGill tendon bench's file with a hostile name (a tendon bench has its own loader)."""
    from tendyn.devices import bundled

    text = bundled("mcgill_bench").read_text(encoding="utf-8")
    text = re.sub(r'^name = "([^"]*)"', lambda m: f"name = {_toml_str(HOSTILE + ' ' + m[1])}", text, count=1,
                  flags=re.M)
    path = folder / "hostile_bench.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _generic_log(src: Path, dst: Path) -> None:
    """The bench's CSV log with force_cmd/force_tendon as the generic columns input_1/output_1, named in
    ``meta.signals`` by the hostile :data:`COLUMN` and ``tendon``."""
    lines = src.read_text(encoding="utf-8").splitlines(keepends=True)
    prefix = "# tendyn-log "
    meta = json.loads(lines[0][len(prefix):])
    meta["signals"] = {"input_1": {"name": COLUMN, "unit": "N"}, "output_1": {"name": "tendon", "unit": "N"}}
    lines[0] = prefix + json.dumps(meta) + "\n"
    k = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    lines[k] = lines[k].replace("force_cmd [", "input_1 [").replace("force_tendon [", "output_1 [")
    dst.write_text("".join(lines), encoding="utf-8")


def _run(argv: list[str]) -> None:
    from tendyn.cli import main

    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        code = main(argv)
    assert code == 0, f"tendyn {' '.join(argv)}: exit {code}: {err.getvalue()}"


def _pages(work: Path) -> dict:
    """Run every command that writes a page on the hostile inputs (the pipelines and sweep, tens of seconds or a
    Dask cluster each: test_slow_pages_are_inert; sweep's page is zwidth's write_beside); name → (page, the
    hostile texts it must show as text). About 15 s of commands on 2 busy cores: one browser pass over 12
    pages, the price of covering every command."""
    from datetime import datetime, timedelta, timezone

    from tendyn.device import load_device
    from tendyn.ident import history as hist

    f = work / FOLDER
    f.mkdir()
    dev, geared, bench = hostile_cable_device(f), hostile_geared_device(f), hostile_bench(f)
    log = f / "exciting.parquet"
    _run(["simulate", str(dev), "exciting", "--duration", "3", "--quiet", "--out", str(log)])
    _run(["simulate", str(bench), "prbs", "--torque", "1", "--duration", "2", "--quiet", "--out", str(f / "p.csv")])
    bench_log = f / "prbs.csv"
    _generic_log(f / "p.csv", bench_log)
    db = f / "history.sqlite"
    loaded = load_device(dev)
    for day, c in enumerate((0.05, 0.05, 0.07)):
        hist.record(loaded, "identify-friction", {"fits": [{"transmission": 1, "coulomb_motor": c,
                                                            "coulomb_motor_std": 0.002, "viscous_motor": 1e-3,
                                                            "viscous_motor_std": 1e-4}]},
                    db=db, created=datetime(2026, 3, 1, tzinfo=timezone.utc) + timedelta(days=day))
    r = lambda name: f / name / "report.html"  # noqa: E731
    both = (HOSTILE, FOLDER)
    runs = {
        "identify": (["identify", str(dev), str(log), "--out", str(f / "params.json"), "--quiet", "--report",
                      str(f / "identify")], r("identify"), both),
        "identify_stream": (["identify", str(dev), str(log), "--stream", "--report", str(f / "identify_stream")],
                            r("identify_stream"), both),
        "validate": (["validate", str(dev), str(f / "params.json"), str(log), "--report", str(f / "validate")],
                     r("validate"), both),
        "maps": (["maps", str(dev), "--points", "3", "--report", str(f / "maps")], r("maps"), both),
        "demo": (["demo", str(dev), "--out", str(f / "demo")], r("demo"), both),
        "demo_geared": (["demo", str(geared), "--out", str(f / "demo_geared")], r("demo_geared"), both),
        "zwidth": (["zwidth", str(dev), "--stiffness", "1000:100000:2", "--damping", "0:0:1", "--modes",
                    "compensated", "--scheduler", "none", "--quiet", "--out", str(f / "zwidth.parquet")],
                   f / "zwidth.html", both),
        "frf": (["frf", str(bench_log), "--input", COLUMN, "--output", "tendon", "--segment", "1000", "--report", str(f / "frf")],
                r("frf"), (FOLDER, COLUMN)),
        "identify_bench": (["identify-bench", str(bench_log), "--input", COLUMN, "--output", "tendon", "--structure", "wiener",
                            "--nonlinearity", "dead-zone", "--order", "2", "--shift", "1", "--validate",
                            str(bench_log), "--report", str(f / "identify_bench")], r("identify_bench"),
                           (FOLDER, COLUMN)),
        "history": (["history", str(dev), "--db", str(db), "--report", str(f / "history")], r("history"), both),
        "claims": (["claims", "--quick", "--only", "C1", "--quiet", "--report", str(f / "claims")], r("claims"),
                   ()),     # its index shows the mode only: no text of the input reaches the page
    }
    for argv, _, _ in runs.values():
        _run(argv)
    return {name: (page, texts) for name, (_, page, texts) in runs.items()}


@pytest.fixture(scope="module")
def browser():
    exe, why = find_chromium()
    if exe is None:
        pytest.skip(f"no headless Chromium: {why}")
    b = Browser(exe)
    yield b
    b.close()


def inert_problems(name: str, seen: dict, texts) -> list[str]:
    """What the browser saw that came from the input as markup, or hostile text that is not shown."""
    p, bad = seen["probe"], []
    if seen["errors"]:
        bad.append(f"{name}: console/script errors {seen['errors']}")
    if p["scripts"] or p["b"] or p["stray_images"] or p["injected"]:
        bad.append(f"{name}: elements from the input: scripts {p['scripts']}, <b> {p['b']}, "
                   f"images {p['stray_images']}, {p['injected'][:3]}")
    for t in texts:
        if t not in p["text"]:
            bad.append(f"{name}: the hostile text {t!r} is not shown as text")
    if not p["csp"] or "script-src 'none'" not in p["csp"] or "default-src 'none'" not in p["csp"]:
        bad.append(f"{name}: no Content-Security-Policy forbidding script and remote loads ({p['csp']!r})")
    return bad


def test_every_page_shows_hostile_text_as_text(tmp_path, browser):
    """Every command that writes a page, on hostile inputs: no script ran, no element or on… attribute came from
    the input, the hostile device name, folder and column name are shown as text, and the page forbids script."""
    bad = []
    for name, (page, texts) in _pages(tmp_path).items():
        assert page.is_file(), name
        bad += inert_problems(name, browser.open(page, None, PROBE), texts)
    assert not bad, "\n".join(bad)


@pytest.mark.slow
def test_slow_pages_are_inert(tmp_path, browser):
    """The pipelines' pages and sweep's (the same publishers as above, ~140 s in all on 2 busy cores): the
    hostile device (S0) or bench (S1, sweep) and the hostile report folder. Runs only when asked:
    `pytest -m slow tests/python/test_report_hostile.py`."""
    f = tmp_path / FOLDER
    f.mkdir()
    dev, bench = hostile_cable_device(f), hostile_bench(f)
    runs = {"pipeline_s0": (["pipeline", "s0", str(dev), "--quick", "--report", str(f / "s0")], (HOSTILE, FOLDER)),
            "pipeline_s1": (["pipeline", "s1", str(bench), "--quick", "--report", str(f / "s1")], (HOSTILE, FOLDER)),
            "pipeline_s2": (["pipeline", "s2", "--quick", "--report", str(f / "s2")], (FOLDER,)),
            "sweep": (["sweep", str(bench), "--param", "k1=20000:400000:2", "--amplitudes", "0.6,2", "--workers",
                       "1", "--quiet", "--out", str(f / "sweep.parquet")], (HOSTILE, FOLDER))}
    bad = []
    for name, (argv, texts) in runs.items():
        _run(argv)
        page = f / "sweep.html" if name == "sweep" else Path(argv[-1]) / "report.html"
        bad += inert_problems(name, browser.open(page, None, PROBE), texts)
    assert not bad, "\n".join(bad)


def test_the_probe_sees_markup_from_the_input(tmp_path, browser):
    """The check can fail: a page that pastes the hostile text raw is caught (script ran, elements injected)."""
    page = tmp_path / "raw.html"
    page.write_text(f"<html><head><title>{HOSTILE}</title></head><body><h1>{HOSTILE}</h1></body></html>",
                    encoding="utf-8")
    bad = inert_problems("raw", browser.open(page, None, PROBE), (HOSTILE,))
    assert any("console" in s for s in bad) and any("elements from the input" in s for s in bad), bad
    assert any("is not shown as text" in s for s in bad) and any("Content-Security-Policy" in s for s in bad), bad


def test_term_name_with_markup_is_refused(tmp_path):
    """A term's name names its columns: letters, digits and _ only, so markup cannot reach a page through it."""
    from tendyn.device import DeviceError, load_device

    text = hostile_cable_device(tmp_path).read_text(encoding="utf-8")
    text += f'[[terms]]\nname = {_toml_str(HOSTILE)}\nkind = "offset"\njoint = 1\n'
    path = tmp_path / "term.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DeviceError, match=r"terms\[1\]\.name"):
        load_device(path)
