"""The routing drawn (issue 31, item 4): `tendyn routing show DEV --report DIR` and every report's index draw the
device as SVG. Checked against the routing table from another route (``tendyn.coupling``: K from the core's
routing, not the drawing's reading of the file): each cable is drawn over exactly the joints its K row crosses,
with the row's winding sense and the pulley radii to one scale; opened in Chromium for serial, differential,
antagonistic and N+1 routings (non-empty, every transmission named, no script)."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from browser import Browser, find_chromium
from tendyn.cli import main
from tendyn.coupling import coupling
from tendyn.devices import load
from tendyn.devices.generate import write_cable_device
from tendyn.drawing import routing_svg

NS = {"s": "http://www.w3.org/2000/svg"}
DEVICES = ["lexos", "diff_wrist", "antagonistic_pair", "tendon_finger"]
_NUM = re.compile(r"-?\d+(?:\.\d+)?")


def _points(d: str) -> list[tuple[float, float]]:
    """The end points of every command of an SVG path (M, L and the end of A)."""
    out = []
    for cmd in re.findall(r"[MLA][^MLAZ]*", d):
        nums = [float(v) for v in _NUM.findall(cmd)]
        out.append((nums[-2], nums[-1]))
    return out


def drawn_crossings(svg: str) -> list[dict]:
    """What the drawing shows, read from its geometry: per cable (in drawing order) the joints it wraps (the joint
    axis each wrap arc is centred on), the side it passes each pulley (+1 above, −1 below) and the pulley radii
    [px]."""
    root = ET.fromstring(svg)
    axes = {int(e.get("data-joint")): float(e.get("x1")) for e in root.iter(f"{{{NS['s']}}}line")
            if e.get("class") == "joint-axis"}
    circles = [e for e in root.iter(f"{{{NS['s']}}}circle") if "pulley" in (e.get("class") or "")]
    out = []
    for g in root.iter(f"{{{NS['s']}}}g"):
        if g.get("class") != "cable":
            continue
        path = next(e for e in g if e.get("class") == "cable-path")
        pts = _points(path.get("d"))
        joints, sides, radii = [], {}, {}
        for w in (e for e in g if e.get("class") == "wrap"):
            (x0, y0), (x1, y1) = _points(w.get("d"))
            xc = 0.5 * (x0 + x1)
            j = min(axes, key=lambda k: abs(axes[k] - xc))
            assert abs(axes[j] - xc) < 0.05, f"a wrap arc between joint axes at x = {xc}"
            joints.append(j)
            # the pulley under the wrap: the circle on this axis nearest to the arc
            pul = min((c for c in circles if abs(float(c.get("cx")) - axes[j]) < 0.05),
                      key=lambda c: min(abs(float(c.get("cy")) - y0), abs(float(c.get("cy")) - y1)))
            cy, r = float(pul.get("cy")), float(pul.get("r"))
            radii[j] = r
            # the strand from the motor reaches this axis at the pulley's top (+) or bottom (−)
            first = next((p for p in pts if abs(p[0] - axes[j]) < 0.05), None)
            sides[j] = 0 if first is None else 1 if first[1] < cy - 0.5 * r else -1 if first[1] > cy + 0.5 * r else 0
        out.append({"name": g.get("data-name"), "joints": joints, "sides": sides, "radii": radii})
    return out


def check_against_routing(dev, svg: str) -> list[str]:
    """Differences between the drawing and the routing table K (rows: transmissions, file order)."""
    c = coupling(dev)
    K = np.asarray(c.K)
    cols = list(c.joint_numbers)
    cables = drawn_crossings(svg)
    problems = []
    if [cb["name"] for cb in cables] != list(c.motors):
        problems.append(f"cables {[cb['name'] for cb in cables]} vs transmissions {list(c.motors)}")
    scales = []
    for i, cb in enumerate(cables):
        crossed = sorted(cols[k] for k in np.flatnonzero(K[i]))
        if sorted(cb["joints"]) != crossed:
            problems.append(f"{cb['name']}: drawn over joints {sorted(cb['joints'])}, its K row crosses {crossed}")
            continue
        t = dev.transmissions[i]
        for j in crossed:
            k = K[i, cols.index(j)]
            if cb["sides"][j] != np.sign(k):
                problems.append(f"{cb['name']}: joint {j} wound {cb['sides'][j]:+d}, K = {k:+g}")
            n = t.reducer_ratio if j == t.joint else 1.0          # K holds the driven radius × reducer
            scales.append(cb["radii"][j] * n / abs(k))
    if scales and np.ptp(scales) > 1e-3 * np.mean(scales):
        problems.append(f"radii not to one scale: px/m from {min(scales):.4g} to {max(scales):.4g}")
    return problems


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("drawn")
    return [write_cable_device(folder, 5, seed=3), write_cable_device(folder, 4, differential=True, seed=5),
            write_cable_device(folder, 3, n_plus_one=True, seed=7)]


@pytest.mark.parametrize("name", DEVICES)
def test_each_cable_is_drawn_over_exactly_the_joints_of_its_K_row(name):
    dev = load(name)
    assert check_against_routing(dev, routing_svg(dev)) == []


def test_generated_devices_are_drawn_as_their_routing(generated):
    for path in generated:
        dev = load(str(path))
        assert check_against_routing(dev, routing_svg(dev)) == [], path.name


def test_the_check_fails_on_a_cable_drawn_over_a_joint_its_row_does_not_cross():
    """The oracle can fail: the first cable of L-EXOS (K row [0.32, 0, 0, 0]) given one more wrap, on joint 3."""
    dev = load("lexos")
    svg = routing_svg(dev)
    root = ET.fromstring(svg)
    x3 = next(float(e.get("x1")) for e in root.iter(f"{{{NS['s']}}}line") if e.get("data-joint") == "3")
    x1 = next(float(e.get("x1")) for e in root.iter(f"{{{NS['s']}}}line") if e.get("data-joint") == "1")
    wrap = re.search(r'<g class="cable" data-transmission="1".*?(<path class="wrap"[^>]*/>)', svg, re.S).group(1)
    moved = re.sub(r"(-?\d+\.\d+),", lambda m: f"{float(m.group(1)) + x3 - x1:.2f},", wrap)
    bad = svg.replace(wrap, wrap + moved, 1)
    assert any("drawn over joints [1, 3], its K row crosses [1]" in p for p in check_against_routing(dev, bad))


def test_devices_without_cables_have_no_drawing_and_text_is_escaped(tmp_path):
    assert routing_svg(load("tx40")) is None and routing_svg(load("cea_branch")) is None
    text = write_cable_device(tmp_path, 2, seed=1).read_text()
    evil = '<script>alert(1)</script> & "x"'
    path = tmp_path / "evil.toml"
    path.write_text(text.replace('name = "j1"', 'name = "j1 <b>&amp;</b>"', 1)
                    .replace('[device]\nname = "', '[device]\nname = "' + evil.replace('"', '\\"') + " ", 1))
    svg = routing_svg(load(str(path)))
    root = ET.fromstring(svg)                                      # well-formed XML
    assert not list(root.iter(f"{{{NS['s']}}}script")) and "<script>" not in svg and "<b>" not in svg
    assert evil in "".join(root.itertext()) and "j1 <b>&amp;</b>" in "".join(root.itertext())


PROBE = r"""(() => {
  const svg = document.querySelector('figure.routing svg');
  if (!svg) return null;
  const box = svg.getBoundingClientRect();
  return {w: box.width, h: box.height, cables: svg.querySelectorAll('g.cable').length,
          names: [...svg.querySelectorAll('text.transmission-name')].map(t => t.textContent),
          text: svg.textContent, scripts: document.scripts.length,
          painted: [...svg.querySelectorAll('path.cable-path')].every(p => p.getTotalLength() > 50)};
})()"""


@pytest.fixture(scope="module")
def browser():
    exe, why = find_chromium()
    if exe is None:
        pytest.skip(f"no headless Chromium: {why}")
    b = Browser(exe)
    yield b
    b.close()


def test_routing_show_report_draws_every_routing_in_chromium(browser, tmp_path, capsys):
    for name in DEVICES:
        out = tmp_path / name
        assert main(["routing", "show", name, "--report", str(out)]) == 0
        assert capsys.readouterr().out.strip().endswith(f"report: {out / 'report.html'}")
        assert (out / "routing.svg").read_text().startswith("<svg") and (out / "routing.json").is_file()
        seen = browser.open(out / "report.html", tmp_path / f"{name}.png", PROBE)
        probe = seen["probe"]
        assert seen["errors"] == [] and probe is not None, (name, seen)
        dev = load(name)
        assert probe["w"] > 300 and probe["h"] > 200 and probe["painted"], (name, probe)
        assert probe["cables"] == len(dev.transmissions) and probe["scripts"] == 0
        for i, t in enumerate(dev.transmissions, start=1):
            assert f"M{i} {t.name}" in probe["names"], (name, probe["names"])
        for j in dev.joint_names:
            assert j in probe["text"]
    # a device without cables: a report without a drawing, and the page still opens
    assert main(["routing", "show", "tx40", "--report", str(tmp_path / "tx40")]) == 0
    assert browser.open(tmp_path / "tx40" / "report.html", None, PROBE)["probe"] is None
