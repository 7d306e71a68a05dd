"""The documentation (issue 20 item 7): `make docs` builds the site from docs/ and the docstrings with warnings as
errors (mkdocs --strict), and every docstring example of the package runs as a doctest."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def test_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("mkdocstrings", reason="mkdocstrings is in the test extra: pip install '.[test]'")
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-f", str(REPO / "mkdocs.yml"),
                        "-d", str(tmp_path / "site")], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stderr[-3000:]
    site = tmp_path / "site"
    for page in ("index.html", "s0.html", "s1.html", "s2.html", "claims.html", "api/claims.html"):
        assert (site / page).is_file(), page
    api = (site / "api" / "claims.html").read_text(encoding="utf-8")
    assert "assert_claim" in api and "Context" in api                      # rendered from the docstrings
    index = (site / "index.html").read_text(encoding="utf-8")
    for fig in ("statics_with_losses.png", "bench_frf_amplitudes.png", "fig7_compensation.png"):
        assert fig in index and (site / "figures" / fig).is_file()         # the README's figures


def _modules_with_examples():
    import tendyn

    for info in pkgutil.walk_packages(tendyn.__path__, "tendyn."):
        spec = importlib.util.find_spec(info.name)
        origin = getattr(spec, "origin", None)
        if origin and origin.endswith(".py") and ">>>" in Path(origin).read_text(encoding="utf-8"):
            yield info.name


MODULES = sorted(_modules_with_examples())


def test_some_docstrings_have_examples():
    assert {"tendyn.claims", "tendyn.progress"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    res = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert res.failed == 0, f"{res.failed} of {res.attempted} examples of {name} failed (run: python -m doctest -v)"
