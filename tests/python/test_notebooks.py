"""The example notebooks (issue 31, item 5): stored without outputs, and each runs top to bottom in a fresh kernel
(nbclient) in a temporary folder: a lab's own device through S0, the TX40 identification, a bench from its logs."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NOTEBOOKS = sorted(EXAMPLES.glob("*.ipynb"))


def test_the_three_notebooks_are_there_and_stored_without_outputs():
    assert {p.name for p in NOTEBOOKS} >= {"lab_device_s0.ipynb", "tx40_identification.ipynb",
                                           "bench_from_logs.ipynb"}
    for path in NOTEBOOKS:
        doc = json.loads(path.read_text(encoding="utf-8"))
        for cell in doc["cells"]:
            if cell["cell_type"] == "code":
                assert cell["outputs"] == [] and cell["execution_count"] is None, f"{path.name}: outputs stored"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path, tmp_path):
    """Every cell runs without error in a fresh kernel; the notebook's files go into tmp_path."""
    nb = nbformat.read(str(path), as_version=4)
    env_path = os.environ.get("PYTHONPATH")           # the kernel runs the same sources as the tests
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute(env={**os.environ, **({"PYTHONPATH": env_path} if env_path else {}),
                        "MPLBACKEND": "Agg"})
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert errors == []
