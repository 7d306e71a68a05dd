"""Example 03: identify the base dynamic parameters of a real Staubli TX40 from its measured data.

The data ship with tendyn (``tendyn data path tx40``: 45 000 samples at 5 kHz of motor encoder angles and motor
torques, with their import map). The same in the shell:

    D=$(tendyn data path tx40)
    tendyn log import $D/pos_read_data.csv $D/curr_data.csv --map $D/import.toml --out tx40.parquet
    tendyn identify tx40 tx40.parquet --out tx40_params.json --report out/tx40

Prints S2-Table-4-like tables (OLS and WLS), cond(W), the relative residual per joint and the cross-validation
on the second half of the trajectory (fitted on the first half).
"""

import sys
from pathlib import Path

from tendyn.data import path as data_path
from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.ident import IDIM
from tendyn.io.importer import import_logs

DATA = data_path("tx40")


def main(out_dir=None) -> int:
    if not DATA.is_dir():
        print(f"the measured TX40 data are not at {DATA}", file=sys.stderr)
        return 1
    log = import_logs([DATA / "pos_read_data.csv", DATA / "curr_data.csv"], DATA / "import.toml")
    dev = load_device(bundled("tx40"))
    for method in ("ols", "wls"):
        est = IDIM(dev, method=method).fit(log)
        print(est.result_)
        print()
        if out_dir is not None:
            from tendyn.io import save_png

            Path(out_dir).mkdir(parents=True, exist_ok=True)
            save_png(est.result_.plot(), Path(out_dir) / f"tx40_{method}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else None))
