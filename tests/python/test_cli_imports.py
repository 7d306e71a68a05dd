"""A quick command line (issue 20 item 6): `tendyn --help` and `tendyn routing show lexos` load none of the heavy
modules (scipy, Dask, CVXPY, matplotlib, Pinocchio, sympy, python-control, pyarrow); commands import them when
they run. Counted in a fresh interpreter (the modules are in sys.modules or not); the wall times are benchmarks
(benchmarks/cli_bench.py: cli_help_latency, cli_routing_show_latency), not tests."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("scipy", "scipy.signal", "dask", "distributed", "cvxpy", "matplotlib", "pinocchio", "sympy", "control",
         "pyarrow", "importlib.metadata")

PROBE = """
import contextlib, io, json, sys
from tendyn.cli import main
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        code = main(json.loads(sys.argv[1]))
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "modules": sorted(sys.modules), "out": out.getvalue()}))
"""


def loaded(argv: list[str]) -> dict:
    r = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv)], capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


@pytest.mark.parametrize("argv", [["--help"], ["routing", "show", "lexos"], ["simulate", "--help"]])
def test_light_commands_load_no_heavy_module(argv):
    doc = loaded(argv)
    assert doc["code"] in (0, None), doc["out"]
    heavy = sorted(m for m in doc["modules"] if m in HEAVY or m.split(".")[0] in HEAVY[:-1])
    assert not heavy, f"`tendyn {' '.join(argv)}` imports {heavy}"
    if argv[0] == "--help":
        assert "claims" in doc["out"] and "identify" in doc["out"]


def test_the_probe_sees_a_heavy_import():
    """The probe can fail: a command that needs scipy.signal shows it (identify-bench's model simulates with it)."""
    code = "import sys; import tendyn.ident.block_simulation as b; b._lfilter([1.0], [1.0], [0.0]); print('scipy.signal' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "True"


def test_version_is_printed_on_demand(capsys):
    from tendyn.cli import main

    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.startswith("tendyn ")
