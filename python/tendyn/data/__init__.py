"""Data sets shipped with tendyn, so that every walkthrough runs on a fresh install (``tendyn data path NAME``).

* ``tx40`` — measured data of a real Stäubli TX40 arm (Apache-2.0, see its PROVENANCE.md): motor encoder angles
  and motor torques of one exciting trajectory at 5 kHz, and the ``tendyn log import`` map of the bundled device
  ``tx40``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["DATASETS", "path"]

DATASETS = {
    "tx40": "Stäubli TX40, measured: pos_read_data.csv (motor angles [rad]), curr_data.csv (motor torques [N·m]), "
            "import.toml (log import map), 45 000 samples at 5 kHz (Apache-2.0, PROVENANCE.md)",
}


def path(name: str) -> Path:
    """The folder of the shipped data set ``name`` (KeyError naming the known ones)."""
    if name not in DATASETS:
        raise KeyError(f"no data set {name!r} (shipped: {', '.join(sorted(DATASETS))})")
    return Path(__file__).resolve().parent / name
