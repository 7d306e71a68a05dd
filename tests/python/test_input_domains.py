"""Every input has a declared domain, checked before any work (issue 34 items 1 and 4's relations): signals
nobody can identify from (`frf`, `identify-bench`), references nobody should send to a motor (`plan`), options
that mean nothing for the chosen kind (`plan`, `export`), coupling files (`routing import`), and a zero driven
radius in `routing show`. Each case was once accepted without a word or ended in an internal error; each is now
one line on stderr, exit 2, naming the option and its domain (tendyn.commands.args: APPLIES_TO, SIGNAL_DOMAINS,
PLAN_RELATIONS, Domain)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.io import make_log, write_log


def _one_line(capsys, argv, *words):
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("tendyn: error:"), (argv, code, err)
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _bench_log(path, n=4000, rate=1000.0, u=None, y=None, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n) if u is None else u
    y = np.convolve(u, [0.5, 0.3, 0.1], mode="full")[:n] + 0.01 * rng.standard_normal(n) if y is None else y
    log = make_log({"time": np.arange(n) / rate, "input_1": u, "output_1": y}, device="bench", rate_hz=rate,
                   seed=None, experiment="prbs", signals={"input_1": {"name": "voltage", "unit": "V"},
                                                          "output_1": {"name": "force", "unit": "N"}})
    return write_log(log, path)


@pytest.fixture
def good(tmp_path):
    return _bench_log(tmp_path / "good.csv")


@pytest.mark.parametrize("case", ["constant_input", "zero_output", "short", "band_above_nyquist",
                                  "segment_longer_than_log", "two_rates"])
def test_frf_refuses_signals_nobody_can_identify_from(tmp_path, capsys, good, case):
    extra, words = [], []
    logs = [good]
    if case == "constant_input":
        logs = [_bench_log(tmp_path / "c.csv", u=np.full(4000, 2.0))]
        words = ["--input", "constant"]
    elif case == "zero_output":
        logs = [_bench_log(tmp_path / "z.csv", y=np.zeros(4000))]
        words = ["--output", "constant"]
    elif case == "short":
        logs = [_bench_log(tmp_path / "s.csv", n=10)]
        words = ["10 samples", "64"]
    elif case == "band_above_nyquist":
        extra, words = ["--band", "10,900"], ["--band", "Nyquist", "500"]
    elif case == "segment_longer_than_log":
        extra, words = ["--segment", "5000"], ["--segment", "4000"]
    else:
        logs = [good, _bench_log(tmp_path / "r2.csv", rate=2000.0)]
        words = ["different sample rates"]
    _one_line(capsys, ["frf", *logs, *extra], *words)


def test_frf_inside_the_domain_runs(capsys, good):
    assert main(["frf", str(good), "--band", "1,500", "--segment", "4000", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)


def test_identify_bench_refuses_constant_and_short_logs(tmp_path, capsys, good):
    const = _bench_log(tmp_path / "c.csv", y=np.zeros(4000))
    base = ["identify-bench", "--structure", "wiener", "--nonlinearity", "polynomial"]
    _one_line(capsys, [*base[:1], const, *base[1:], "--validate", good], "--output", "constant")
    short = _bench_log(tmp_path / "s.csv", n=10)
    _one_line(capsys, [*base[:1], good, *base[1:], "--validate", short], "s.csv", "10 samples")
    other = _bench_log(tmp_path / "r.csv", rate=500.0)
    _one_line(capsys, [*base[:1], good, *base[1:], "--validate", other], "different sample rates")


PLAN_CASES = {
    "amplitude beyond the bound": (["prbs", "--amplitude", "1e308", "--duration", "1"], ["--amplitude", "10000"]),
    "clock above the rate": (["prbs", "--amplitude", "1", "--duration", "1", "--clock", "5000"], ["--clock", "1000"]),
    "multisine above Nyquist": (["multisine", "--amplitude", "1", "--duration", "2", "--band", "1,600"],
                                ["--band", "500"]),
    "stepped sine twice": (["stepped-sine", "--amplitude", "1", "--frequencies", "5,7,5"], ["--frequencies", "5"]),
    "stepped sine above rate/4": (["stepped-sine", "--amplitude", "1", "--frequencies", "5,300"],
                                  ["--frequencies", "250"]),
    "exciting 0 iterations": (["exciting", "lexos", "--iterations", "0"], ["--iterations", "1 ≤"]),
    "exciting --transmission": (["exciting", "lexos", "--transmission", "1"], ["--transmission", "constant-velocity"]),
    "prbs --harmonics": (["prbs", "--amplitude", "1", "--duration", "1", "--harmonics", "3"], ["--harmonics"]),
    "constant-velocity --clock": (["constant-velocity", "lexos", "--transmission", "1", "--clock", "10"], ["--clock"]),
}


@pytest.mark.parametrize("case", sorted(PLAN_CASES))
def test_plan_refuses_references_nobody_should_send(tmp_path, capsys, case):
    argv, words = PLAN_CASES[case]
    device = [] if argv[0] in ("exciting", "constant-velocity") else ["mcgill_bench"]
    out = tmp_path / "ref.csv"
    _one_line(capsys, ["plan", argv[0], *device, *argv[1:], "--out", out], *words)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv,words", [
    (["mjcf", "lexos", "--four-bar"], ["--four-bar", "ros2-control"]),
    (["ros2-control", "lexos", "--lossless"], ["--lossless", "mjcf"]),
    (["mjcf", "lexos", "--k", "0.5"], ["--k", "compensator"]),
    (["transmission", "lexos", "--timestep", "0.01"], ["--timestep", "mjcf"]),
])
def test_export_refuses_options_meaningless_for_the_kind(tmp_path, capsys, argv, words):
    suffix = {"mjcf": ".xml", "ros2-control": ".urdf", "transmission": ".model"}[argv[0]]
    _one_line(capsys, ["export", *argv, "--out", tmp_path / f"o{suffix}"], *words)


def test_every_applies_row_names_options_of_its_parser():
    """The table is bound to the parsers at build (tendyn.commands.args.applies asserts every name exists)."""
    from tendyn.cli import build_parser
    from tendyn.commands.args import APPLIES_TO

    build_parser()
    assert set(APPLIES_TO) == {"plan", "export"}


def _coupling(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("case", ["deep", "nan", "too_big", "huge_entry", "ragged"])
def test_routing_import_refuses_bad_coupling_files(tmp_path, capsys, case):
    from tendyn.devices.generate import write_cable_device

    dev = write_cable_device(tmp_path, 2, seed=1)
    eye = lambda n: [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]  # noqa: E731
    text, words = {
        "deep": ('{"a":' * 50_000 + "1" + "}" * 50_000, ["nested"]),
        "nan": ('{"coupling": {"JointToActuatorPosition": [[NaN, 0], [0, 1]]}}', ["NaN"]),
        "too_big": (json.dumps({"coupling": {"JointToActuatorPosition": eye(100)}}), ["100×100", "64×64"]),
        "huge_entry": ('{"coupling": {"JointToActuatorPosition": [[1e300, 0], [0, 1]]}}', ["1e+06"]),
        "ragged": ('{"coupling": {"JointToActuatorPosition": [[1, 0, 3], [0, 1]]}}', ["ragged"]),
    }[case]
    src = _coupling(tmp_path, "c.json", text)
    _one_line(capsys, ["routing", "import", dev, src, "--out", tmp_path / "o.toml"], *words)
    assert not (tmp_path / "o.toml").exists()


def test_routing_show_of_a_zero_driven_radius_is_shown_not_a_crash(tmp_path, capsys):
    """Two cables that each wrap only the other joint (a zero diagonal of K, driven_radius = 0 written literally,
    K invertible): `routing show` ended in ZeroDivisionError; the ratio column now says — for them."""
    import re

    from tendyn.devices.generate import cable_device_toml

    text = cable_device_toml(2, name="zd", seed=1)
    blocks = text.split("[[transmissions]]")
    t1 = re.sub(r"(?m)^crosses = .*$", "crosses = [2]", blocks[1])
    t1 = re.sub(r"(?m)^crossed_radii = .*$", "crossed_radii = [0.03]", t1)
    t1 = re.sub(r"(?m)^friction = \[(\{[^}]*\})\]$", r"friction = [\1, \1]", t1)
    t2 = blocks[2]
    t1, t2 = (re.sub(r"(?m)^driven_radius = .*$", "driven_radius = 0.0", t) for t in (t1, t2))
    p = tmp_path / "zd.toml"
    p.write_text("[[transmissions]]".join([blocks[0], t1, t2, *blocks[3:]]))
    code = main(["routing", "show", str(p)])
    out = capsys.readouterr()
    assert code == 0 and "driven_radius = 0" in out.out, out.err
    assert main(["routing", "show", str(p), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["joint_per_motor_ratio"] for r in doc["routing"]] == [0.0, 0.0]


def test_friction_file_beyond_the_schema_bound_is_refused(tmp_path, capsys):
    """Physical bounds at every door (issue 34 item 6): a FRICTION.json whose Coulomb level is 1e308 N·m is refused
    naming the field and the schema's bound (it was written into a compensator)."""
    n = 4
    doc = {"format": "tendyn.friction/1", "device": "L-EXOS", "n_transmissions": n,
           "coulomb_motor": [1e308] + [0.01] * (n - 1), "viscous_motor": [0.001] * n,
           "fits": [{"transmission": t, "coulomb_motor": 0.01, "viscous_motor": 0.001, "coulomb_motor_std": 1e-4,
                     "viscous_motor_std": 1e-5} for t in range(1, n + 1)]}
    path = tmp_path / "f.json"
    path.write_text(json.dumps(doc))
    _one_line(capsys, ["export", "compensator", "lexos", "--friction", path, "--out", tmp_path / "o.comp"],
              "coulomb_motor[1]", "1e+06")
    assert not (tmp_path / "o.comp").exists()


@pytest.mark.parametrize("field,line,needle", [
    ("tau0", "tau0 1e308" + " 1" * 15, "<= 1e6 [N]"),
    ("pretension", "pretension 1e7 50 50 50", "pretension[0] = 10000000: must be <= 1e6"),
    ("reducer_ratio", None, "reducer_ratio"),
])
def test_compensator_file_beyond_the_core_bounds_is_refused(tmp_path, field, line, needle):
    """The C++ loader (the one the C ABI and Compensator.load share) refuses a coefficient beyond the bound the
    device schema declares, the bound in the message (include/tendyn/routing.hpp transmission_field_bounds)."""
    import re
    from pathlib import Path

    from tendyn.control import Compensator

    text = (Path(__file__).resolve().parents[2] / "examples" / "02_compensation" / "lexos.comp").read_text()
    if line is None:        # K's diagonal and driven_radius * reducer_ratio stay consistent: ratio 2e4 > 1e4
        line = "reducer_ratio 20000 1 1 1"
        m = re.search(r"(?m)^driven_radius (\S+)", text)
        r = float(m.group(1))
        text = re.sub(r"(?m)^K (\S+)", f"K {r * 20000!r}", text)
    text = re.sub(rf"(?m)^{field} .*$", line, text, count=1)
    p = tmp_path / "bad.comp"
    p.write_text(text)
    with pytest.raises(ValueError, match=re.escape(needle)):
        Compensator.load(p)


def test_the_core_bounds_are_the_schemas():
    """transmission_field_bounds (C++) against the device schema's specs: read from the header's text (the same
    numbers, so a bound changed on one side fails here)."""
    import re
    from pathlib import Path

    from tendyn.device.schema import BEARING_FIELDS, FRICTION_FIELDS, TRANSMISSION_FIELDS

    hpp = (Path(__file__).resolve().parents[2] / "include" / "tendyn" / "routing.hpp").read_text()
    core = {m.group(1): float(m.group(2)) for m in re.finditer(r'\{"(\w+)", ([0-9.e]+), "must', hpp)}
    specs = {s.name: s for s in TRANSMISSION_FIELDS + FRICTION_FIELDS}
    specs.update({"bearing_" + s.name: s for s in BEARING_FIELDS})
    checked = 0
    for name, bound in core.items():
        spec = specs.get(name)
        if spec is None:
            continue
        schema_bound = spec.hi if spec.hi is not None else spec.abs_max
        if schema_bound is not None:
            assert bound == schema_bound, (name, bound, schema_bound)
            checked += 1
    assert checked >= 10, core
