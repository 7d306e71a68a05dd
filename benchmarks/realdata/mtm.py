"""dVRK MTM (WPI's two measured trajectories and joint-4 cable sweep, ../shared/external-data/dvrk_mtm, no licence:
read from there only) against WPI's published per-joint test errors; discovered by benchmarks/realdata/run.py.

Both tendyn fits use the MTM described as a user would (mtm_device.py: public DH, parallelogram closed loop,
dVRK coupling as [[actuators]], wrist-pitch spring) with the joint-4 cable torque fitted by tendyn itself from
the sweep (``TermFit``, the code of ``tendyn identify-term``), identified on trajectory ``one``, predicted on
``two`` (``IdentifiedModel.predict``), scored with WPI's metric (mtm_device.wpi_metric):

* ``tendyn_preset``: ``--treatment wpi --method wls --consistent``;
* ``tendyn_default``: tendyn's default treatment (device bandwidth 1 Hz: WPI's trajectories reach 0.6 Hz) with
  ``--method wls --consistent``, and the device file adds an identified ``polynomial`` term (degree 5) on the
  platform on top of the sweep's known cable torque: the sweep was taken in one pose, the cable's torque in the
  trajectories' poses differs (measured: joint 4 at 0.229 without it, 0.209 with it; WPI 0.223).

And two checks of WPI's pipeline: ``wpi_params`` (WPI's published parameters, params.json, converted to tendyn's
standard parameters and predicted with the ``wpi`` treatment and WPI's cable: WPI's errors within 3.2 %, so the
treatment, model and metric are theirs) and :func:`bounded_errors` (the preset with WPI's SDP boxes,
:func:`wpi_bounds`, solved to convergence: far from WPI's numbers, whose point lies outside those boxes).
"""

from __future__ import annotations

import functools
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mtm_device import WPI_ERRORS, mtm_device_text, mtm_log, wpi_metric  # noqa: E402

WPI_CABLE = (0.0004877, -0.0037149, 0.0067497, 0.008519, -0.0201475, -0.025265, 0.048095, 0.00255)
"""WPI's joint-4 cable polynomial, highest power first (main_mtm.ipynb cell 42): the metric's denominator."""

BANDWIDTH_HZ = 1.0

PLATFORM_CORRECTION = '\n[[terms]]\nname = "cable4_pose"\nkind = "polynomial"\njoint = 6\ndegree = 5\n'
"""The identified polynomial on the platform (file joint 6) of the default fit."""


WPI_SDP_ROWS = (
    (2, 20, -0.1, 0.1, -0.1, 0.1, -0.1, 0.3, 0.2, 0.2, 0.2, 0, 0),
    (1, 15, -0.1, 0.15, -0.05, 0.05, -0.05, 0.05, 0.2, 0.2, 0.3, 0, 0),
    (0.5, 5, 0.0, 0.3, -0.03, 0.03, -0.03, 0.03, 0.2, 0.2, 0.2, 0, 0),
    (1, 10, -0.1, 0.1, -0.05, 0.05, -0.1, 0.1, 0.2, 0.2, 0.3, 0, 0),
    (0.05, 2, 0.05, 0.2, -0.02, 0.02, 0.02, 0.1, 0.2, 0.2, 0.2, 0, 0),
    (0.05, 2, -0.03, 0.03, 0.0, 0.12, -0.15, 0.0, 0.2, 0.2, 0.2, 0, 0),
    (0.05, 1, -0.02, 0.02, -0.1, 0.0, -0.1, 0.0, 0.2, 0.2, 0.2, 250, 300),
    (0.05, 0.5, -0.02, 0.02, 0, 0.1, -0.1, 0.0, 0.2, 0.2, 0.2, 0, 0),
    (0.02, 0.5, -0.01, 0.01, -0.01, 0.01, 0.0, 0.1, 0.2, 0.2, 0.2, 0, 0),
    (0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.2, 0.2, 0, 0))
"""WPI's SDP boxes (main_mtm.ipynb cell 94), one row per frame of their model (links 1, 2, 3, 3', 3'', 4, 5, 6, 7 =
tendyn's file joints 1-9; the last row is motor 4): (min m [kg], max m, min/max of the centre of mass x, y, z [m],
max Fc [N·m], max Fv [N·m·s/rad], max |Fo| [N·m], min K, max K [N/m]); their SDPOpt adds Fc, Fv ≥ 0.001 and the
motor-4 inertia ≥ 0.001 kg·m² (identification/sdp_opt.py)."""
WPI_MIN_FRICTION = 0.001
WPI_MIN_ROTOR = 0.001


def wpi_bounds() -> dict:
    """WPI's boxes as ``IDIM(bounds=...)`` on tendyn's MTM device. Frames with the same velocity in tendyn's
    parametrization are summed: joint 3 carries WPI's links 3 and 3'' (velocities q̇3 and −q̇3: FS3, FV3 bounds
    doubled); WPI's link 3' is motor 3 (FSm3, FVm3); WPI's last frame is motor 4 (FSm6, FVm6, IAm6). Offsets: WPI
    has one per frame; tendyn one per joint, which is the sum mapped by virtual work (OFFSET2 = Fo2 + Fo3',
    OFFSET3 = Fo3 − Fo3'' + Fo3' + 0.6697 Fo_m4, OFFSET6 = Fo4 + Fo_m4): the box of each sum (an outer bound)."""
    from mtm_device import COUPLING_4_3

    b = {}
    rows = WPI_SDP_ROWS
    for j, r in enumerate(rows[:9], start=1):
        b[f"M{j}"], b[f"CX{j}"], b[f"CY{j}"], b[f"CZ{j}"] = r[0:2], r[2:4], r[4:6], r[6:8]
    lo = WPI_MIN_FRICTION
    for name, k in (("1", 0), ("2", 1), ("6", 5), ("7", 6), ("8", 7), ("9", 8), ("m3", 3), ("m6", 9)):
        b[f"FS{name}"], b[f"FV{name}"] = (lo, rows[k][8]), (lo, rows[k][9])
    b["FS3"], b["FV3"] = (2 * lo, rows[2][8] + rows[4][8]), (2 * lo, rows[2][9] + rows[4][9])
    fo = [r[10] for r in rows]
    for j, v in ((1, fo[0]), (2, fo[1] + fo[3]), (3, fo[2] + fo[4] + fo[3] + COUPLING_4_3 * fo[9]),
                 (6, fo[5] + fo[9]), (7, fo[6]), (8, fo[7]), (9, fo[8])):
        b[f"OFFSET{j}"] = (-v, v)
    b["IAm6"] = (WPI_MIN_ROTOR, None)
    b["wrist_spring_k"] = (rows[6][11], rows[6][12])
    return b


def _rotations_at_zero() -> dict:
    """Absolute rotation of each file frame at q = 0 (modified DH: R_j = R_a(j) Rx(alpha_j) Rz(theta_j)), from
    mtm_device's table: WPI writes its parameters in the base frame's orientation at q = 0 (cell 112)."""
    p2 = math.pi / 2
    table = {1: (0, 0.0, 0.0), 2: (1, -p2, p2), 3: (2, 0.0, p2), 4: (1, -p2, math.pi), 5: (4, 0.0, -p2),
             6: (3, -p2, 0.0), 7: (6, p2, 0.0), 8: (7, -p2, p2), 9: (8, -p2, math.pi)}
    rx = lambda a: np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    rz = lambda a: np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    R = {0: np.eye(3)}
    for j in range(1, 10):
        a, alpha, theta = table[j]
        R[j] = R[a] @ rx(alpha) @ rz(theta)
    return R


def wpi_published_standard(shared: Path, model) -> np.ndarray:
    """WPI's published parameters (params.json: per frame the inertia about the centre of mass and the centre of
    mass, both in the base frame's orientation at q = 0, mass, Fc, Fv, Fo, rotor inertia, spring K) as tendyn's
    standard parameters (``model.standard_names``): inertia about the frame's origin in the link frame
    (L = R^T I R + m S(c)^T S(c), Khalil's XX…ZZ), first moments m c; frictions and offsets summed as in
    :func:`wpi_bounds`; no rotor inertia but motor 4's."""
    from mtm_device import COUPLING_4_3

    P = json.loads((data(shared) / "params.json").read_text(encoding="utf-8"))
    R = _rotations_at_zero()
    x = dict.fromkeys(model.standard_names, 0.0)
    skew = lambda r: np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    for j in range(1, 10):
        f = P[str(j)]
        v = f["I"]
        inertia = R[j].T @ np.array([[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]]) @ R[j]
        c, m = R[j].T @ np.array(f["r"], float), float(f["m"])
        L = inertia + m * skew(c).T @ skew(c)
        for k, (a, b) in zip(("XX", "XY", "XZ", "YY", "YZ", "ZZ"), ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
            x[f"{k}{j}"] = L[a, b]
        x[f"MX{j}"], x[f"MY{j}"], x[f"MZ{j}"], x[f"M{j}"] = m * c[0], m * c[1], m * c[2], m
    fr = lambda k: (P[str(k)]["Fc"], P[str(k)]["Fv"], P[str(k)]["Fo"])
    for j in (1, 2, 6, 7, 8, 9):
        x[f"FS{j}"], x[f"FV{j}"], x[f"OFFSET{j}"] = fr(j)
    (c3, v3, o3), (c5, v5, o5), (c4, v4, o4), (cm, vm, om) = fr(3), fr(5), fr(4), fr(10)
    x["FS3"], x["FV3"], x["OFFSET3"] = c3 + c5, v3 + v5, o3 - o5 + o4 + COUPLING_4_3 * om
    x["FSm3"], x["FVm3"] = c4, v4
    x["OFFSET2"] += o4
    x["FSm6"], x["FVm6"], x["IAm6"] = cm, vm, P["10"]["Im"]
    x["OFFSET6"] += om
    x["wrist_spring_k"] = P["7"]["K"]
    return np.array([x[n] for n in model.standard_names])


def wpi_cable_term() -> str:
    """WPI's typed cable polynomial (cell 42) as a ``known`` [[terms]] entry on the platform (file joint 6)."""
    c = WPI_CABLE[::-1]
    fn = " + ".join([repr(c[0])] + [f"({v!r})*q**{k}" for k, v in enumerate(c) if k])
    return f'[[terms]]\nname = "cable4"\nkind = "known"\njoint = 6\nfunction = "{fn}"\n'


def data(shared: Path) -> Path:
    return Path(shared) / "external-data" / "dvrk_mtm"


def cable_fit(shared: Path):
    """tendyn's cable torque of dVRK joint 4 from the sweep (TermFit polynomial order 7, defaults)."""
    from tendyn.ident.term_fit import TermFit

    d = np.loadtxt(data(shared) / "joint4_cable_sweep.csv", delimiter=",")
    return TermFit("polynomial", 7).fit(d[:, 0], d[:, 1], d[:, 2])


def device(shared: Path, folder: Path, extra: str = "", cable: str = "tendyn"):
    """The MTM device file written in ``folder`` and loaded: the cable torque of the platform as a ``known`` term,
    tendyn's sweep fit (``cable="tendyn"``) or WPI's typed polynomial (``"wpi"``), plus ``extra`` TOML."""
    from tendyn.device import load_device

    term = cable_fit(shared).term_toml("cable4", 6, "joint4_cable_sweep.csv") if cable == "tendyn" else \
        wpi_cable_term()
    text = mtm_device_text(term + extra)
    Path(folder).mkdir(parents=True, exist_ok=True)
    path = Path(folder) / "dvrk_mtm.toml"
    path.write_text(text.replace("bandwidth_hz = 2.0", f"bandwidth_hz = {BANDWIDTH_HZ!r}"), encoding="utf-8")
    return load_device(path)


def _wpi_cable_motor(model, a):
    """WPI's cable torque in motor space (5999, 7) [N·m] at the logged positions of ``a`` (the raw rows)."""
    q4 = (np.linalg.solve(model.G, a[:, :7].T).T)[:, 3]
    tau = np.zeros((a.shape[0], 7))
    tau[:, 3] = np.polyval(WPI_CABLE, q4)
    return np.linalg.solve(model.G.T, tau.T).T


@functools.lru_cache(maxsize=2)
def errors(shared: Path) -> dict:
    """WPI's metric on ``two`` (7,) of: ``preset`` and ``default`` (tendyn's fits on ``one``), ``wpi_params``
    (WPI's published parameters, params.json, predicted by tendyn with the wpi treatment and WPI's cable: checks
    tendyn's model, treatment and metric against WPI's numbers with WPI's solver out of the loop), and
    ``wpi`` (WPI's published errors)."""
    from tendyn.ident import IDIM
    from tendyn.ident.estimate import cached_model
    from tendyn.ident.identified import IdentifiedModel

    with tempfile.TemporaryDirectory() as tmp:
        devs = {"preset": device(shared, Path(tmp) / "p"), "default": device(shared, Path(tmp) / "d",
                                                                           PLATFORM_CORRECTION),
                "wpi_params": device(shared, Path(tmp) / "w", cable="wpi")}
        one, two = mtm_log(data(shared) / "one_results.csv"), mtm_log(data(shared) / "two_results.csv")
        csv = data(shared) / "two_results.csv"
        c = _wpi_cable_motor(cached_model(devs["preset"]), np.loadtxt(csv, delimiter=","))
        out = {"wpi": np.array(WPI_ERRORS)}
        for key, kw in (("preset", {"treatment": "wpi"}), ("default", {})):
            est = IDIM(devs[key], method="wls", consistent=True, **kw).fit(one, crossval=False)
            out[key] = wpi_metric(csv, est.predict(two, filter_prediction=False).motor, c)
            if key == "preset":
                d = est.result_.to_dict()
        model = cached_model(devs["wpi_params"])
        xb = dict(zip(model.base.names, model.base.combination @ wpi_published_standard(shared, model)))
        params = [dict(p, value=float(xb[p["name"]])) for p in d["params"]]
        pred = IdentifiedModel(devs["wpi_params"], params, d["method"], d["treatment"]).predict(
            two, filter_prediction=False)
        out["wpi_params"] = wpi_metric(csv, pred.motor, c)
    return out


def bounded_errors(shared: Path) -> dict:
    """The ``wpi`` preset fitted on ``one`` with WPI's SDP boxes (:func:`wpi_bounds`), solved to convergence
    (Clarabel), with tendyn's and with WPI's cable: WPI's metric on ``two`` (7,) each (``make realdata`` only:
    two more SDPs, ≈ 10 s)."""
    from tendyn.ident import IDIM
    from tendyn.ident.estimate import cached_model

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        one, two = mtm_log(data(shared) / "one_results.csv"), mtm_log(data(shared) / "two_results.csv")
        csv = data(shared) / "two_results.csv"
        for cable in ("tendyn", "wpi"):
            dev = device(shared, Path(tmp) / cable, cable=cable)
            c = _wpi_cable_motor(cached_model(dev), np.loadtxt(csv, delimiter=","))
            est = IDIM(dev, method="wls", consistent=True, treatment="wpi", bounds=wpi_bounds()).fit(
                one, crossval=False)
            out[cable] = wpi_metric(csv, est.predict(two, filter_prediction=False).motor, c)
    return out


REPO = Path(__file__).resolve().parents[2]
SCS126 = REPO / "build" / "scs126" / "venv" / "bin" / "python"
"""WPI's solver, SCS 1.2.6, in its own environment (``make scs126``: benchmarks/realdata/build_scs126.sh)."""

WPI_NO_ROTOR = ("IA1", "IA2", "IAm3", "IA7", "IA8", "IA9")
"""tendyn's rotor inertias WPI's model does not have (it has motor 4's only, tendyn's IAm6): held at 0."""

WPI_SOLVER_INFO = {"eps": 1e-3, "alpha": 1.5, "max_iters": 10000, "lin_sys": "sparse-indirect",
                   "residual": 4.8984e-2, "iterations": 10000, "variables": 123, "constraints": 39421,
                   "linear": 136, "soc": 39195, "psd_blocks": 9, "psd_vars": 90}
"""WPI's SCS run (main_mtm.ipynb cell 95's log): settings, final primal residual |Ax + s − b| / (1 + |b|), and the
problem's size (122 parameters + the epigraph variable; 39193 rows + 2 in the second-order cone; 136 linear
rows; 9 PSD blocks of 4 × 4)."""


def scs126_solver(python: Path = SCS126, log: dict | None = None, settings: dict | None = None, stream=None):
    """A ``solve`` for :func:`tendyn.ident.consistent.consistent_fit`: the cvxpy problem's SCS standard form
    (``get_problem_data``) solved by SCS 1.2.6 in its own environment (_scs126_solve.py, WPI's settings, or
    ``settings`` over them), the raw solution unpacked by cvxpy into the variables. ``log`` (a dict) receives
    SCS's info (status, iterations, primal residual, seconds) and the problem's size; ``stream``: a file that
    receives SCS's iteration log while it runs (else it is kept in ``log["output"]``)."""
    import subprocess

    import cvxpy as cp

    def solve(prob):
        data, chain, inverse = prob.get_problem_data(cp.SCS)
        A, dims = data["A"].tocsc(), data["dims"]
        size = {"variables": A.shape[1], "constraints": A.shape[0], "zero": dims.zero, "linear": dims.nonneg,
                "soc": [int(v) for v in dims.soc], "psd": [int(v) for v in dims.psd]}
        with tempfile.TemporaryDirectory() as tmp:
            src, dst = Path(tmp) / "problem.npz", Path(tmp) / "solution.npz"
            np.savez(src, A_data=A.data, A_indices=A.indices, A_indptr=A.indptr, A_shape=np.array(A.shape),
                     b=data["b"], c=data["c"], zero=dims.zero, nonneg=dims.nonneg, soc=np.array(size["soc"]),
                     psd=np.array(size["psd"]), settings=json.dumps(settings or {}))
            out = open(stream, "w", encoding="utf-8") if stream else subprocess.PIPE   # SCS's log, as it runs
            try:
                run = subprocess.run([str(python), "-u", str(Path(__file__).with_name("_scs126_solve.py")), str(src),
                                      str(dst)], stdout=out, stderr=subprocess.PIPE, text=True)
            finally:
                if stream:
                    out.close()
            if run.returncode != 0:
                raise RuntimeError(f"SCS 1.2.6 failed: {run.stderr.strip()[-500:]}")
            sol = np.load(dst)
            info = json.loads(str(sol["info"]))
            raw = {"x": sol["x"], "y": sol["y"], "s": sol["s"], "info": info}
        prob.unpack_results(raw, chain, inverse)
        if log is not None:
            log.update(info, size=size, output=run.stdout or "")
    return solve


def wpi_sdp(solve=None) -> dict:
    """``IDIM(sdp=...)`` for WPI's problem: WPI's form (:data:`tendyn.ident.consistent.FORMS`), the rotor inertias
    WPI does not have held at 0, solved by ``solve`` (None: Clarabel)."""
    return {"form": "wpi", "fixed": dict.fromkeys(WPI_NO_ROTOR, 0.0), **({"solve": solve} if solve else {})}


class _Shape(Exception):
    pass


def wpi_sdp_shape(shared: Path) -> dict:
    """The size of the SDP tendyn builds for WPI's problem (the ``wpi`` preset on ``one``, WPI's boxes, WPI's
    form), as SCS sees it: variables, constraints, linear rows, second-order cone, PSD blocks; not solved."""
    import cvxpy as cp

    from tendyn.ident import IDIM

    size = {}

    def stop(prob):
        data, _, _ = prob.get_problem_data(cp.SCS)
        d = data["dims"]
        size.update(variables=data["A"].shape[1], constraints=data["A"].shape[0], zero=d.zero, linear=d.nonneg,
                    soc=[int(v) for v in d.soc], psd=[int(v) for v in d.psd], boxes=len(wpi_bounds()))
        raise _Shape

    with tempfile.TemporaryDirectory() as tmp:
        dev = device(shared, Path(tmp) / "w", cable="wpi")
        one = mtm_log(data(shared) / "one_results.csv")
        try:
            IDIM(dev, method="wls", consistent=True, treatment="wpi", bounds=wpi_bounds(),
                 sdp=wpi_sdp(stop)).fit(one, crossval=False)
        except _Shape:
            pass
    return size


def wpi_solver_errors(shared: Path, python: Path = SCS126, stream=None) -> dict:
    """The ``wpi`` preset on ``one`` with WPI's boxes, WPI's form and WPI's solver (SCS 1.2.6, WPI's settings) and
    WPI's cable: WPI's metric on ``two`` (``errors``, (7,)), the base parameters against WPI's published ones
    through tendyn (``base_rel_diff``: ‖x − x_WPI‖ / ‖x_WPI‖ over the base parameters, ``base_max_rel``: the
    largest |x_i − x_WPI,i| / max|x_WPI|), SCS's info (``scs``) and the wall time (``seconds``)."""
    import time

    from tendyn.ident import IDIM
    from tendyn.ident.estimate import cached_model

    log = {}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        dev = device(shared, Path(tmp) / "w", cable="wpi")
        one, two = mtm_log(data(shared) / "one_results.csv"), mtm_log(data(shared) / "two_results.csv")
        csv = data(shared) / "two_results.csv"
        model = cached_model(dev)
        c = _wpi_cable_motor(model, np.loadtxt(csv, delimiter=","))
        est = IDIM(dev, method="wls", consistent=True, treatment="wpi", bounds=wpi_bounds(),
                   sdp=wpi_sdp(scs126_solver(python, log, stream=stream))).fit(one, crossval=False)
        e = wpi_metric(csv, est.predict(two, filter_prediction=False).motor, c)
        d = est.result_.to_dict()
        mine = np.array([p["value"] for p in d["params"]])
        wpi_base = dict(zip(model.base.names, model.base.combination @ wpi_published_standard(shared, model)))
        theirs = np.array([wpi_base[p["name"]] for p in d["params"]])
    diff = mine - theirs
    return {"errors": e, "base_rel_diff": float(np.linalg.norm(diff) / np.linalg.norm(theirs)),
            "base_max_rel": float(np.max(np.abs(diff)) / np.max(np.abs(theirs))), "names": [p["name"] for p in d["params"]],
            "base": mine, "wpi_base": theirs, "scs": {k: v for k, v in log.items() if k != "output"},
            "seconds": time.perf_counter() - t0}


def rows(shared: Path, bounded: bool = True) -> list[dict]:
    """One row per joint; extra keys: WPI's parameters through tendyn and, ``bounded``, the preset with WPI's
    boxes (with tendyn's and with WPI's cable; None when not ``bounded``) and the preset with WPI's boxes, form and
    solver (``tendyn_preset_wpi_solver``: SCS 1.2.6, None when not ``bounded`` or not built, ``make scs126``)."""
    e = errors(Path(shared))
    b = bounded_errors(Path(shared)) if bounded else {"tendyn": [None] * 7, "wpi": [None] * 7}
    s = wpi_solver_errors(Path(shared))["errors"] if bounded and SCS126.is_file() else [None] * 7
    f = lambda v: None if v is None else float(v)
    return [{"dataset": "dvrk_mtm", "peer": "WPI (main_mtm.ipynb)", "metric": "relative error on two",
             "item": f"joint {j + 1}", "peer_value": float(e["wpi"][j]), "tendyn_preset": float(e["preset"][j]),
             "tendyn_default": float(e["default"][j]), "unit": "-",
             "wpi_params_through_tendyn": float(e["wpi_params"][j]),
             "tendyn_preset_wpi_bounds": f(b["tendyn"][j]),
             "tendyn_preset_wpi_bounds_wpi_cable": f(b["wpi"][j]),
             "tendyn_preset_wpi_solver": f(s[j])} for j in range(7)]


if __name__ == "__main__":
    shared = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[3] / "shared"
    for r in rows(shared):
        print(f"{r['item']}: WPI {r['peer_value']:.3f}  preset {r['tendyn_preset']:.4f}  "
              f"default {r['tendyn_default']:.4f}  WPI's parameters {r['wpi_params_through_tendyn']:.4f}  "
              f"preset + WPI's boxes {r['tendyn_preset_wpi_bounds']:.4f} / {r['tendyn_preset_wpi_bounds_wpi_cable']:.4f}  "
              f"+ WPI's solver {r['tendyn_preset_wpi_solver']}")
