"""Stäubli TX40 against FIGAROH (thanhndv212/figaroh-plus, examples/staubli_TX40, snapshot c3b5172): its
identification of the 9 s, 5 kHz exciting log (reference/TX40_bp_5.csv: 60 base parameters, OLS and WLS, each
with its %σ), reproduced by ``--treatment figaroh`` and compared with tendyn's defaults, on the log and on a
split of it.

FIGAROH's parametrization of the coupled wrist differs from tendyn's (regressor.add_coupling_TX40): its motor-6
columns are [q̈6, q̇6] on joint 5's rows and [q̈5, q̇5] on joint 6's, where the motor's own inertia and viscous
friction act on q̇m6 / 32 = q̇5 + q̇6 on both (tendyn); so FIGAROH's fv5 = FV5 + 32² FVm6, fv6 = FV6 + 32² FVm6,
Ia5 = IA5 + 32² IAm6, and its motor-6 parameters are joint-side (fvm6 = 32² FVm6, fsm6 = 32 FSm6,
Iam6 = 32² IAm6). :func:`figaroh_values` maps tendyn's to FIGAROH's, :func:`tendyn_values` back.

The split (docs/realdata.md): the log's two halves, 4.5 s each, each fitted and the other predicted (the split
``identify``'s own cross-validation uses, chosen before measuring); relative error ‖Y − W X‖ / ‖Y‖ on the
unseen half treated with tendyn's defaults, the same rows for every parameter set.
"""

from __future__ import annotations

import csv
import functools
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
PEER = "FIGAROH (examples/staubli_TX40, TX40_bp_5.csv)"
DQ_LIM_DEF = (0.05009095, 0.05009095, 0.07504916, 0.0715585, 0.05585054, 0.12217305)
"""FIGAROH's TX40 config (T40X_config.yaml, dq_lim_def) [rad/s]: its per-joint velocity thresholds."""
MOTOR6_RATIO = 32.0
"""Motor 6's ratio (tendyn's tx40 device file and FIGAROH's config N[5]) for the change of parametrization."""
SPLITS = {"second half (fit on the first)": ((0.0, 0.5), (0.5, 1.0)),
          "first half (fit on the second)": ((0.5, 1.0), (0.0, 0.5))}


def folder(shared: Path) -> Path:
    f = Path(shared) / "external-data" / "staubli_tx40"
    if not (f / "reference" / "TX40_bp_5.csv").is_file():
        raise FileNotFoundError(str(f / "reference" / "TX40_bp_5.csv"))
    return f


def load(shared: Path):
    """The log (tendyn's import map of the TX40 files, python/tendyn/data/tx40/import.toml)."""
    from tendyn.data import path as data_path
    from tendyn.io.importer import import_logs

    f = folder(shared)
    return import_logs([f / "pos_read_data.csv", f / "curr_data.csv"], data_path("tx40") / "import.toml")


def device():
    from tendyn.devices import load as load_device

    return load_device("tx40")


def tendyn_name(figaroh: str) -> str:
    """FIGAROH's base-parameter expression → tendyn's name (``Izz1 + 1.0*Ia1 + ...`` → ``ZZ1R``)."""
    head, *rest = figaroh.replace(" - ", " + ").split(" + ")
    head = head.strip()
    special = {"Iam6": "IAm6", "fvm6": "FVm6", "fsm6": "FSm6"}
    if head in special:
        return special[head]
    stem, num = head[:-1], head[-1]
    stems = {"Ixx": "XX", "Ixy": "XY", "Ixz": "XZ", "Iyy": "YY", "Iyz": "YZ", "Izz": "ZZ", "mx": "MX", "my": "MY",
             "mz": "MZ", "m": "M", "Ia": "IA", "fv": "FV", "fs": "FS", "off": "OFFSET"}
    return stems[stem] + num + ("R" if rest else "")


def reference(shared: Path) -> dict:
    """{tendyn name: (ols, ols %σ, wls, wls %σ)} of FIGAROH's published TX40_bp_5.csv."""
    out = {}
    with open(folder(shared) / "reference" / "TX40_bp_5.csv", newline="") as fh:
        for row in csv.reader(fh):
            out[tendyn_name(row[0])] = tuple(float(v) for v in row[1:5])
    return out


def figaroh_values(names, x) -> np.ndarray:
    """tendyn's base parameters ``x`` (names) in FIGAROH's parametrization (module docstring)."""
    d = dict(zip(names, map(float, x)))
    k = MOTOR6_RATIO ** 2
    f = dict(d)
    f["FV5"], f["FV6"], f["IA5"] = d["FV5"] + k * d["FVm6"], d["FV6"] + k * d["FVm6"], d["IA5"] + k * d["IAm6"]
    f["FVm6"], f["FSm6"], f["IAm6"] = k * d["FVm6"], MOTOR6_RATIO * d["FSm6"], k * d["IAm6"]
    return np.array([f[n] for n in names])


def tendyn_values(names, fig) -> np.ndarray:
    """The inverse of :func:`figaroh_values`."""
    f = dict(zip(names, map(float, fig)))
    k = MOTOR6_RATIO ** 2
    d = dict(f)
    d["FVm6"], d["FSm6"], d["IAm6"] = f["FVm6"] / k, f["FSm6"] / MOTOR6_RATIO, f["IAm6"] / k
    d["FV5"], d["FV6"], d["IA5"] = f["FV5"] - f["FVm6"], f["FV6"] - f["FVm6"], f["IA5"] - f["IAm6"]
    return np.array([d[n] for n in names])


def observations(log, parts=None, **kw):
    """(Y, W_base, rows, n_active) of the log (or the fraction ``parts`` of it) with the options ``kw``."""
    from tendyn.ident import IDIM

    est = IDIM(device(), **kw)
    Y, W, rows, _, na = est.observations(log, parts)
    return est, Y, W[:, list(est._model().base.columns)], rows, na


def solve(obs, method="ols") -> np.ndarray:
    est, Y, W, rows, na = obs
    return est._solve(W, Y, rows, na, method)[0]


def relative_error(obs, x) -> tuple[float, np.ndarray]:
    """‖Y − W x‖ / ‖Y‖ [-] of the rows ``obs`` and per joint."""
    _, Y, W, rows, na = obs
    r = Y - W @ x
    return (float(np.linalg.norm(r) / np.linalg.norm(Y)),
            np.array([np.linalg.norm(r[rows == j]) / np.linalg.norm(Y[rows == j]) for j in range(na)]))


def preset_observations(log, parts=None):
    return observations(log, parts, treatment="figaroh", velocity_threshold=DQ_LIM_DEF)


@functools.lru_cache(maxsize=2)
def measured(shared: Path) -> dict:
    """Every number of the rows: the preset and default fits (OLS, WLS) in FIGAROH's parametrization, and the
    relative errors of the published, preset and default parameters on each unseen half and on the whole log."""
    from tendyn.ident.estimate import cached_model

    log = load(shared)
    ref = reference(shared)
    names = list(cached_model(device()).base.names)
    pre, dflt = preset_observations(log), observations(log)
    out = {"names": names, "ref": ref, "fit": {}}
    for m in ("ols", "wls"):
        out["fit"][("preset", m)] = figaroh_values(names, solve(pre, m))
        out["fit"][("default", m)] = figaroh_values(names, solve(dflt, m))
    published = tendyn_values(names, [ref[n][0] for n in names])      # FIGAROH's OLS, in tendyn's terms
    out["split"] = {}
    for item, (fit_p, test_p) in SPLITS.items():
        test = observations(log, test_p)
        out["split"][item] = {"peer": relative_error(test, published),
                              "preset": relative_error(test, solve(preset_observations(log, fit_p))),
                              "default": relative_error(test, solve(observations(log, fit_p)))}
    out["split"]["whole log (in-sample for both)"] = {"peer": relative_error(dflt, published),
                                                      "preset": relative_error(dflt, solve(pre)),
                                                      "default": relative_error(dflt, solve(dflt))}
    return out


def rows(shared: Path) -> list[dict]:
    from tendyn.ident.estimate import cached_model

    m = measured(Path(shared))
    model = cached_model(device())
    out = []
    for k, (m_, col) in enumerate((("ols", 0), ("wls", 2))):
        for i, n in enumerate(m["names"]):
            pv, ps = m["ref"][n][col], m["ref"][n][col + 1]
            if m_ == "wls" and ps >= 5.0:
                continue                    # WLS rows: only the parameters FIGAROH determines (%σ < 5)
            out.append({"dataset": "tx40", "peer": PEER, "metric": f"parameter ({m_.upper()}, FIGAROH's "
                        "parametrization)", "item": n, "peer_value": pv,
                        "tendyn_preset": float(m["fit"][("preset", m_)][i]),
                        "tendyn_default": float(m["fit"][("default", m_)][i]), "unit": model.unit(n),
                        "peer_rel_stderr_pct": ps})
    for item, e in m["split"].items():
        out.append({"dataset": "tx40", "peer": PEER, "metric": "relative error, joint space (published OLS vs "
                    "fits on the other part)", "item": item, "peer_value": e["peer"][0] * 100,
                    "tendyn_preset": e["preset"][0] * 100, "tendyn_default": e["default"][0] * 100, "unit": "%",
                    "per_joint_peer": list(e["peer"][1]), "per_joint_preset": list(e["preset"][1]),
                    "per_joint_default": list(e["default"][1])})
    return out


def figures(shared: Path) -> list:
    from tendyn.ident import IDIM

    log = load(shared)
    est = IDIM(device()).fit(log, crossval=False)
    return [("tendyn's default model on the log (fitted on all of it)", est.predict(log))]
