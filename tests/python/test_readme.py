"""The README runs (issue 17, item 8): its ``sh`` and ``python`` code blocks, extracted from README.md itself (not a
copy), run in order in an empty folder with the installed package, as a new user would paste them. A block after the
marker ``<!-- readme-test: skip … -->`` (the set-up that runs this test) is skipped."""

import os
import re
import subprocess
import sys
from pathlib import Path


README = Path(__file__).resolve().parents[2] / "README.md"
BLOCK = re.compile(r"(<!-- readme-test: skip[^>]*-->\s*)?```(sh|python)\n(.*?)```", re.S)


def readme_blocks():
    """(language, code, skipped) of every sh/python block of README.md, in order."""
    return [(m.group(2), m.group(3), m.group(1) is not None) for m in BLOCK.finditer(README.read_text("utf-8"))]


def test_readme_has_the_walkthrough_blocks():
    blocks = readme_blocks()
    run = [b for b in blocks if not b[2]]
    assert len(run) >= 4 and {lang for lang, _, _ in run} == {"sh", "python"}
    text = "\n".join(code for _, code, _ in run)
    for needed in ("identify-friction", "export compensator", "tendyn data path tx40", "read_log"):
        assert needed in text
    assert "../shared" not in text and "examples/" not in text     # nothing that assumes the repository


def test_readme_blocks_run_in_order(tmp_path):
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
               MPLBACKEND="Agg")
    for k, (lang, code, skipped) in enumerate(readme_blocks()):
        if skipped:
            continue
        cmd = ["bash", "-euo", "pipefail", "-c", code] if lang == "sh" else [sys.executable, "-c", code]
        r = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, f"README block {k + 1} ({lang}) failed:\n{code}\n--- stderr ---\n{r.stderr[-3000:]}"
    assert (tmp_path / "lexos.comp").exists() and (tmp_path / "tx40_params.json").exists()
