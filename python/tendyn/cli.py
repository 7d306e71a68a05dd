"""The `tendyn` command. Parses arguments and calls the packages; no physics lives here.

Every command that computes something takes ``--json`` and then prints its main results as one
JSON document on stdout; progress and logs go to stderr.

Exit codes: 0 done; 1 a computed result failed a check (e.g. a diverged simulation); 2 bad input
(an option, a device file, a log, an output path), always one line ``tendyn: error: …`` on stderr and
nothing written; 3 an unexpected error (one line; ``--debug`` shows the traceback); 130 interrupted
(outputs already written are kept, nothing is half-written). A closed pipe ends the command quietly.
"""

from __future__ import annotations

import contextlib
import functools
import argparse
import json
import os
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tendyn.commands.shared import check_out_folder as _check_out_folder, load as _load, print_json as _print_json
from tendyn.commands.shared import version as _version
from tendyn.errors import CheckFailed, UsageError, flag

if TYPE_CHECKING:  # numpy is imported by the commands that compute (`tendyn config` must start fast)
    import numpy as np


# ---- parsing --------------------------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``--joint: must be 1…4 (got 0)`` raised as UsageError."""

    def error(self, message: str):
        message = re.sub(r"^argument ([^:]+?)(/[^:]+)?: ", lambda m: m.group(1) + ": ", message)
        raise UsageError(f"{message} (see `{self.prog} --help`)")


def _typed(name: str):
    """argparse type of catalogue option ``name``: parse and check, message without the option."""
    from tendyn.sim import catalogue

    def convert(text: str):
        try:
            return catalogue.parse(name, text)
        except UsageError as exc:
            raise argparse.ArgumentTypeError(exc.problem) from None

    convert.__name__ = name
    opt = catalogue.OPTIONS[name]
    if opt.kind in ("float", "int", "seed", "floats"):       # the declared domain, read by the domain fuzz
        from tendyn.commands.args import Domain

        seed = opt.kind == "seed"
        convert.domain = Domain(0 if seed else opt.lo, 2 ** 64 - 1 if seed else opt.hi, opt.lo_open,
                                opt.kind in ("int", "seed"), opt.unit, many=opt.kind == "floats")
    return convert


_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)


def _join_negative_values(argv: list[str], value_flags: set[str]) -> list[str]:
    """``--q0 -0.1,0.2`` → ``--q0=-0.1,0.2``: argparse would read a negative list as an option."""
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if a in value_flags and i + 1 < len(argv) and _NEGATIVE_VALUE.match(argv[i + 1]):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def build_parser() -> argparse.ArgumentParser:
    from tendyn.sim import catalogue

    p = _Parser(prog="tendyn", description="Tendon transmissions: model, simulate, identify, compensate.")
    p.add_argument("--debug", action="store_true", help="show the traceback of an unexpected error")
    p.add_argument("--version", action=_VersionAction, nargs=0, help="show the version and exit")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    routing = sub.add_parser("routing", help="transmission routing and matrices")
    rsub = routing.add_subparsers(dest="action", required=True, parser_class=_Parser)
    show = rsub.add_parser("show", help="print the routing table and the four matrices")
    show.add_argument("device", help="device file (.toml) or bundled twin name (lexos, …)")
    show.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    show.add_argument("--max-joint-torque", default=None, metavar="TAU[,TAU…]",
                      help="N+1 devices: the joint torque box |τ_j| ≤ TAU_j [N·m] (one value, or one per joint) "
                           "whose minimum pretension is reported (default: the largest uniform box the motors' "
                           "peak tensions serve)")
    show.add_argument("--report", type=_report_dir, default=None, metavar="DIR",
                      help="write report.html (the routing drawn: joints, pulleys to scale, each cable's path and "
                           "winding), routing.svg, routing.json and routing.txt into DIR")
    show.set_defaults(func=cmd_routing_show)
    imp = rsub.add_parser("import", help="write an [[actuators]] device file from a coupling matrix file (dVRK, "
                                         "libbarrett, iCub or plain)")
    imp.add_argument("device", help="device file (.toml) or bundled twin name: the kinematics to keep")
    imp.add_argument("coupling", help="coupling file: dVRK JSON, libbarrett .conf, iCub XML or a plain matrix")
    imp.add_argument("--format", choices=("auto", "dvrk", "libbarrett", "icub", "plain"), default="auto",
                     help="format of the coupling file (default: from its suffix: .json dVRK, .conf/.cfg libbarrett, "
                          ".xml iCub, else plain rows of G)")
    imp.add_argument("--out", required=True, help="the device file to write (.toml, atomically)")
    imp.add_argument("--json", action="store_true", help="print a summary as JSON on stdout")
    imp.set_defaults(func=cmd_routing_import)

    epilog = "experiments: " + "; ".join(f"{e.name} ({'tendon bench' if e.kind != 'serial' else 'chains'}): {e.help}"
                                         for e in catalogue.EXPERIMENTS.values())
    sim = sub.add_parser("simulate", help="run an experiment on a twin and write its log", epilog=epilog)
    sim.add_argument("device", help="device file (.toml) or bundled twin name")
    sim.add_argument("experiment", choices=catalogue.EXPERIMENT_NAMES)
    sim.add_argument("--out", required=True, help="log file (.parquet or .csv); the truth goes beside it")
    for name, opt in catalogue.OPTIONS.items():
        unit = f" [{opt.unit}]" if opt.unit not in ("-", "") else ""
        sim.add_argument(flag(name), type=_typed(name), default=None, help=opt.help + unit,
                         metavar=_metavar(opt))
    sim.add_argument("--quiet", action="store_true", help="no progress bar")
    sim.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    sim.set_defaults(func=cmd_simulate)

    demo = sub.add_parser("demo", help="the main job of a device in one command: figures + data")
    demo.add_argument("device", nargs="?", default="lexos")
    demo.add_argument("--out", default="out/demo", help="output folder [default: out/demo]")
    demo.add_argument("--json", action="store_true")
    demo.set_defaults(func=cmd_demo)
    _register_commands(sub)
    return p


@functools.cache
def _main_parser() -> argparse.ArgumentParser:
    """The parser :func:`main` reuses (built on its first call): building one is ~15 ms (270 options, argparse's
    gettext and terminal-size lookups for each), which a program or a test calling :func:`main` thousands of times
    in one process paid every time. Reuse is safe: parsing leaves the parser as it was (each call gets a new
    namespace; the options' converters are pure, every default immutable: test_cli), and the parser depends only on
    the package (the catalogue and the commands are fixed at import: no default read from the environment)."""
    return build_parser()


def _register_commands(sub) -> None:
    """The subcommands of :mod:`tendyn.commands`, one module each, found without a list to keep."""
    import importlib
    import pkgutil

    import tendyn.commands as commands

    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        module = importlib.import_module(f"tendyn.commands.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)


class _VersionAction(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata is slow to import)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"tendyn {_version()}")
        parser.exit()


def _metavar(opt) -> str:
    return {"floats": "X,…", "choice": "|".join(opt.choices), "int": "N", "seed": "N"}.get(opt.kind, "X")


# ---- routing show ---------------------------------------------------------------------------------

def cmd_routing_show(args) -> int:
    """The coupling of any device (:func:`tendyn.coupling.coupling`), with its routing, drives or actuators."""
    from tendyn.coupling import coupling

    dev = _load(args.device)
    if dev.kind != "serial":
        raise UsageError(f"{dev.name} is a tendon bench (one 2N channel): it has no routing to show", "device")
    c = coupling(dev)
    doc = c.to_dict()
    head: list[str] = []
    if getattr(dev, "n_plus_one", False):
        head = _tendon_lines(dev, doc, args.max_joint_torque)
    elif args.max_joint_torque is not None:
        raise UsageError("is for N+1 devices ([device] routing = \"n_plus_one\")", "max_joint_torque")
    elif c.actuation == "transmissions":
        head = _routing_lines(dev, doc)
    elif c.actuation == "drives":
        head = _drive_lines(dev, doc)
    else:
        head = _actuator_lines(dev, doc)
    text = "\n".join(head) + "\n" + c.table()
    if args.report is not None:
        doc["report"] = str(_routing_report(args, dev, doc, text))
    if args.json:
        doc["n"] = c.n_motors
        _print_json(doc)
        return 0
    from tendyn.text import printable

    print(printable(text))     # names and paths come from files: no control character reaches the tty
    if args.report is not None:
        print(f"report: {printable(doc['report'])}")
    return 0


def _report_dir(text: str):
    from tendyn.commands.args import report_dir

    return report_dir(text)


def _routing_report(args, dev, doc: dict, text: str) -> Path:
    """``routing show --report DIR``: the page (the drawing in its index), routing.svg, routing.json, routing.txt."""
    from tendyn.drawing import routing_svg
    from tendyn.report import Section, write_report

    svg = routing_svg(dev)
    texts = {"routing.txt": text}
    if svg is not None:
        texts["routing.svg"] = svg
    why = ("The drawing above (in the index) shows the routing: one column per joint, one row per transmission, "
           "pulley radii to scale." if svg is not None else
           "This device has no cables to draw: its motors drive the joints through [[drives]] or [[actuators]].")
    sections = [Section("Routing table and coupling", text=why, tables=[text])]
    return write_report(args.report, "routing show", args, doc, "routing.json", sections, texts=texts, device=dev,
                        title=f"tendyn routing show: {dev.name}")


def cmd_routing_import(args) -> int:
    """A coupling file → G → ``[[actuators]]`` rows (file's motor order) on the device's kinematics, checked by
    loading the written file back and comparing its G."""
    import tempfile

    import numpy as np

    from tendyn.coupling import coupling
    from tendyn.device import DeviceError, load_device
    from tendyn.io import atomic_write_text
    from tendyn.io.coupling_file import (CouplingFileError, actuator_entries, device_text, fit_to_device,
                                         read_coupling)

    from tendyn.commands.args import out_path

    try:
        out = out_path((".toml",))(args.out)      # suffix, existing and writable folder, not a folder itself
    except argparse.ArgumentTypeError as exc:
        raise UsageError(str(exc), "out") from None
    src = Path(args.coupling)
    if not src.is_file():
        raise UsageError(f"{src}: file not found")
    dev = _load(args.device)
    if dev.kind != "serial":
        raise UsageError(f"{dev.name} is a tendon bench (one 2N channel): it has no joint chain", "device")
    if out.resolve() == Path(dev.path).resolve():
        raise UsageError(f"{out} is the input device file: write the new device elsewhere", "out")
    joint_numbers = coupling(dev).joint_numbers
    priors = None
    if dev.actuators:
        priors = [{"encoder_offset": a.encoder_offset, "rotor_inertia": a.rotor_inertia,
                   "viscous_motor": a.viscous_motor, "coulomb_motor": a.coulomb_motor,
                   "torque_constant": a.torque_constant} for a in dev.actuators]
    try:
        G, fmt = read_coupling(src, args.format)
        G = fit_to_device(G, len(joint_numbers), src.name)
        entries = actuator_entries(G, joint_numbers, priors)
    except CouplingFileError as exc:
        raise UsageError(str(exc)) from None
    text = device_text(Path(dev.path).read_text(encoding="utf-8"), Path(dev.path).parent, out.parent, entries,
                       f"{src.name} ({fmt})")
    with tempfile.NamedTemporaryFile("w", suffix=".toml", dir=out.parent, delete=False, encoding="utf-8") as fh:
        fh.write(text)
    try:
        new = load_device(Path(fh.name))
    except DeviceError as exc:
        raise UsageError(f"the imported coupling does not make a valid device: {exc}") from None
    finally:
        Path(fh.name).unlink(missing_ok=True)
    G_back = coupling(new).G
    if not np.allclose(G_back, G, rtol=1e-12, atol=1e-12 * np.abs(G).max()):
        raise CheckFailed(f"the written [[actuators]] do not reproduce the coupling (largest difference "
                          f"{np.abs(G_back - G).max():.3g})")
    atomic_write_text(out, text)
    doc = {"out": str(out), "device": dev.name, "format": fmt, "coupling_file": str(src),
           "motor_from_joint_position": G.tolist(),
           "actuators": [{"motor": e["name"], "joint": e["joint"], "ratio": e["ratio"], "coupling": e["coupling"]}
                         for e in entries]}
    if args.json:
        _print_json(doc)
        return 0
    print(f"{out}: {len(entries)} [[actuators]] from {src.name} ({fmt}) on the kinematics of {dev.name}")
    for e in doc["actuators"]:
        coup = ", ".join(f"{c:+g}·q{k}" for k, c in e["coupling"].items())
        print(f"  {e['motor']}: joint {e['joint']}, N = {e['ratio']:g}" + (f", coupling {coup}" if coup else ""))
    return 0


def _routing_lines(dev, doc: dict) -> list[str]:
    import numpy as np

    from tendyn.transmission import Transmission

    tr = Transmission.from_device(dev)
    doc["routing"] = tr.routing_table()
    lines = [f"{dev.name}: {tr.n} tendon transmissions (transmission i drives joint i)",
             f"{'tr':>3} {'r_m [mm]':>9}  {'signed radius at joints 1…i [mm]':<36} {'pulley':>7} {'n':>5} "
             f"{'eta_d':>6} {'q/q_m':>7}"]
    for row in doc["routing"]:
        radii = " ".join(f"{1e3 * r:+7.1f}" for r in row["radius_at_joint_m"][:-1])
        lines.append(f"{row['transmission']:>3} {1e3 * row['motor_radius_m']:9.2f}  {radii:<36} "
                     f"{1e3 * row['driven_radius_m']:7.1f} {row['reducer_ratio']:5.1f} "
                     f"{row['reducer_efficiency']:6.2f} " + (f"{1 / row['joint_per_motor_ratio']:7.4f}"
                                                             if row['joint_per_motor_ratio'] else f"{'—':>7}"))
    if any(not row["joint_per_motor_ratio"] for row in doc["routing"]):     # a zero diagonal (driven_radius = 0)
        lines.append("— : the cable does not wrap its own joint (driven_radius = 0): no ratio of its own")
    lines.append("\nR_m q_m = K q (S0 eqs. 1–2, corrected); G = R_m⁻¹K; τ_J = Kᵀ t, C_m = R_m t (eq. 5, corrected)")
    lines.append(_matrix_text("K", np.asarray(doc["K"]), "m"))
    return lines


def _tendon_lines(dev, doc: dict, max_joint_torque: str | None) -> list[str]:
    """An N+1 device: the tendons, K, P, the null vector h and the minimum pretension of a joint torque box."""
    import numpy as np

    from tendyn.tendons import Tendons

    td = Tendons.from_device(dev)
    if max_joint_torque is None:
        box = np.full(td.n, td.largest_torque_box())
        how = "the largest uniform box the motors' peak tensions serve"
    else:
        try:
            vals = [float(v) for v in max_joint_torque.split(",")]
        except ValueError:
            raise UsageError(f"expected numbers [N·m] separated by commas (got {max_joint_torque!r})",
                             "max_joint_torque") from None
        if len(vals) not in (1, td.n) or not all(np.isfinite(v) and v >= 0 for v in vals):
            raise UsageError(f"one value or {td.n} values (one per joint), finite and >= 0 [N·m] (got "
                             f"{max_joint_torque!r})", "max_joint_torque")
        box = np.broadcast_to(np.array(vals), (td.n,)).copy()
        how = "given"
    tdoc = td.to_dict(box)
    tdoc["peak_tension"] = td.peak_tension.tolist()
    doc["tendons"] = tdoc
    doc["units"].update({"null_vector": "-", "tension_from_torque": "1/m", "minimum_pretension": "N",
                         "max_joint_torque": "N·m", "tension_min": "N", "peak_tension": "N"})
    h = td.null_vector
    lines = [f"{dev.name}: {td.m} tendons share {td.n} joints (N+1, [device] routing = \"n_plus_one\"); tendon i = "
             "row i, sorted by the joint it ends on",
             f"{'tendon':>12} {'r_m [mm]':>9}  {'signed radius at joints 1…n [mm]':<34} {'floor [N]':>9} "
             f"{'peak [N]':>9} {'h':>8}"]
    K = td.K
    for i, name in enumerate(td.names):
        radii = " ".join(f"{1e3 * r:+7.1f}" for r in K[i])
        lines.append(f"{name:>12} {1e3 * td.motor_radius[i]:9.2f}  {radii:<34} {td.tension_min[i]:9.3g} "
                     f"{td.peak_tension[i]:9.4g} {h[i]:8.4f}")
    lines.append("\nℓ̇ = K q̇; τ_J = Kᵀ t, C_m = R_m t (virtual work); t = P τ + λ h with P = pinv(Kᵀ), Kᵀ h = 0, "
                 "h > 0 (tension closure)")
    lines.append(_matrix_text("K", K, "m"))
    lines.append(_matrix_text("P = pinv(Kᵀ)", td.tension_from_torque, "1/m"))
    lines.append(_matrix_text("null vector h", h[None, :], "-"))
    lam = tdoc["minimum_pretension"]
    lines.append(f"  minimum pretension λ for |τ_j| ≤ [{', '.join(f'{v:.4g}' for v in box)}] N·m ({how}): "
                 f"{lam:.6g} N; tensions at rest λh = [{', '.join(f'{v:.4g}' for v in lam * h)}] N")
    return lines


def _drive_lines(dev, doc: dict) -> list[str]:
    from tendyn.capstan import CapstanDrives

    cap = CapstanDrives.from_device(dev)
    doc["drives"] = cap.drive_table()
    doc["K"] = cap.matrices()["K"].tolist()                       # diag(N), kept for the JSON contract
    doc["units"]["K"] = "- (capstan ratio: q_m = K q)"
    lines = [f"{dev.name}: {cap.n} capstan drives (motor i drives active joint i through ratio N; drives are "
             "listed by the joint they drive)"]
    for d in doc["drives"]:
        lines.append(f"  {d['drive']}: joint {d['joint']}, N = {d['ratio']:g}, K_T = {d['stiffness_motor_Nm_rad']:g} "
                     f"N·m/rad (motor side), Coulomb {d['coulomb_motor_Nm']:.4g} N·m, viscous "
                     f"{d['viscous_motor_Nms_rad']:.3g} N·m·s/rad")
    return lines


def _actuator_lines(dev, doc: dict) -> list[str]:
    doc["actuators"] = [{"motor": a.name, "joint": a.joint, "ratio": a.ratio,
                         "coupling": {str(k): c for k, c in a.coupling}, "encoder_offset_rad": a.encoder_offset,
                         "rotor_inertia_kgm2": a.rotor_inertia, "viscous_motor_Nms_rad": a.viscous_motor,
                         "coulomb_motor_Nm": a.coulomb_motor} for a in dev.actuators]
    lines = [f"{dev.name}: {len(dev.actuators)} geared motors ([[actuators]], in the file's order): "
             "q_motor = N (q_joint + Σ coupling·q_k)"]
    for a in doc["actuators"]:
        coup = ", ".join(f"{c:+g}·q{k}" for k, c in a["coupling"].items())
        lines.append(f"  {a['motor']}: joint {a['joint']}, N = {a['ratio']:g}" + (f", coupling {coup}" if coup else "")
                     + (f", encoder offset {a['encoder_offset_rad']:+.4g} rad" if a["encoder_offset_rad"] else ""))
    return lines


def _matrix_text(name: str, M: np.ndarray, unit: str) -> str:
    from tendyn.coupling import matrix_text

    return matrix_text(name, M, unit)


# ---- simulate -------------------------------------------------------------------------------------

def cmd_simulate(args) -> int:
    import time

    from tqdm import tqdm

    from tendyn import _core
    from tendyn.sim import catalogue

    dev = _load(args.device)
    opts = catalogue.resolve(dev, args.experiment, {k: getattr(args, k) for k in catalogue.OPTIONS})
    out = _check_log_path(args.out)
    bar = tqdm(total=1, unit="step", unit_scale=True, file=sys.stderr, disable=args.quiet or None,
               desc=f"{dev.name}: {args.experiment}")

    def progress(done, total):
        bar.total = total
        bar.n = done
        bar.refresh()

    t0 = time.perf_counter()
    try:
        runs = catalogue.run(dev, args.experiment, opts, progress)
    except _core.SimulationDiverged as exc:   # Status::Diverged from the core: the result, not the input
        raise CheckFailed(f"the simulation diverged ({exc}); try a higher --rate") from None
    finally:
        bar.close()
    wall = time.perf_counter() - t0

    from tendyn.io.files import interrupts_deferred

    written = []
    with interrupts_deferred():     # a Ctrl-C while writing: every run's pair written, then exit 130
        for k, run in enumerate(runs):
            path = out if len(runs) == 1 else out.with_name(f"{out.stem}_{k + 1:02d}{out.suffix}")
            log_path, truth_path = _write_run(run.log, run.truth, path)
            written.append({"log": str(log_path), "truth": str(truth_path), "n_samples": run.log.n_samples,
                            "duration_s": float(run.log.time[-1] - run.log.time[0])})
    simulated = sum(w["duration_s"] for w in written)
    summary = {"device": dev.name, "experiment": args.experiment, "seed": opts["seed"],
               "options": {k: v for k, v in opts.items() if v is not None},
               "log_rate_hz": runs[0].log.meta["rate_hz"],
               "logs": written, "wall_s": wall, "simulated_s_per_wall_s": simulated / wall if wall else None}
    if args.json:
        _print_json(summary)
    else:
        for w in written:
            print(f"{w['log']}: {w['n_samples']} samples, {w['duration_s']:.2f} s simulated (truth: {w['truth']})")
        print(f"wall {wall:.2f} s, {summary['simulated_s_per_wall_s']:.1f} simulated s per wall s")
    return 0


def _check_log_path(text: str) -> Path:
    from tendyn.io.logs import LogError, check_log_path

    try:
        return check_log_path(text)
    except LogError as exc:
        raise UsageError(str(exc), "out") from None


def _write_run(log, truth, path: Path):
    from tendyn.io.logs import write_run

    return write_run(log, truth, path)


# ---- demo -----------------------------------------------------------------------------------------

def cmd_demo(args) -> int:
    global _DEMO_STEP
    from tendyn.io.files import all_or_none
    from tendyn.progress import Ticker

    _DEMO_STEP = Ticker("demo")               # a bar on a terminal, `[demo] step …` lines otherwise

    dev = _load(args.device)
    out = _check_out_folder(args.out)
    if dev.kind != "serial":
        job = _demo_bench
    elif not dev.transmissions:
        job = _demo_capstan
    else:
        job = _demo_cables
    with all_or_none(out) as stage:       # every file of the demo, or none of them
        outputs = _Outputs(stage, out)
        doc, lines = job(dev, outputs)
        warnings = outputs.report(dev, args, doc)
    _DEMO_STEP.close()
    doc["report"] = str(out / "report.html")
    lines.append(f"report: {doc['report']}")
    if args.json:
        _print_json(doc)
    else:
        from tendyn.text import printable

        print(printable("\n".join(lines)))
    sys.stdout.flush()
    from tendyn.report import warn

    warn("demo", warnings)
    return 0


_DEMO_STEP = print


class _Outputs:
    """Writes a result's figure (PNG) and data (JSON) into the staging folder; names their final paths."""

    def __init__(self, stage: Path, final: Path):
        self.stage, self.final, self.results = stage, final, []

    def save(self, result, stem: str) -> tuple[Path, Path]:
        """The result's data now; its figure (PNG, and SVG in the page) with :meth:`report`."""
        from tendyn.io import atomic_write_text, to_jsonable

        atomic_write_text(self.stage / f"{stem}.json", json.dumps(to_jsonable(result.to_dict())))
        self.results.append((stem, result))
        return self.final / f"{stem}.png", self.final / f"{stem}.json"

    def report(self, dev, args, doc) -> list:
        """report.html (and each figure as STEM.png) for the saved results; returns its warnings."""
        from tendyn.report import run_info, section_of, write_html_report

        sections = [section_of(stem.replace("_", " "), r, name=stem) for stem, r in self.results]
        _, warnings = write_html_report(self.stage, f"Demo of {dev.name}", run_info("demo", device=dev, options=args),
                                        sections, data=doc, json_name="demo.json", pngs=True,
                                        extra_files=[f"{stem}.json" for stem, _ in self.results])
        return warnings


def _demo_cables(dev, outputs: _Outputs):
    from tendyn.pipelines.friction_sweep import friction_sweep
    from tendyn.pipelines.statics_demo import statics_demo

    _DEMO_STEP(f"statics with losses on {dev.name}")
    demo = statics_demo(dev)
    fig, data = outputs.save(demo, "statics_with_losses")
    lines = []
    for s in demo.sweeps:
        k = len(s.torque_joint) - 1
        lines.append(f"joint {s.joint + 1}: to deliver {s.torque_joint[k]:+.2f} N·m at {s.speed:+.1f} rad/s "
                     f"the motor needs {s.motor_positive_speed[k]:+.4f} N·m (lossless {s.motor_lossless[k]:+.4f}); "
                     f"back-driven at {-s.speed:+.1f} rad/s {s.motor_negative_speed[k]:+.4f} N·m")
    lines.append(f"figure: {fig}")
    doc = {"device": dev.name, "figure": str(fig), "data": str(data)}
    if dev.n_joints >= 2:
        _DEMO_STEP(f"constant-velocity tests on the {dev.name} twin (S1, S2)")
        sweep = friction_sweep(dev, transmission=1)
        fig2, data2 = outputs.save(sweep, "constant_velocity_tests")
        for name, (v, c) in sweep.points.items():
            pairs = ", ".join(f"{vi:+.0f} rad/s: {ci:+.4f}" for vi, ci in zip(v, c))
            lines.append(f"{name}: mean motor-{sweep.transmission} torque [N·m] at {pairs}")
        lines.append(f"figure: {fig2}")
        doc["constant_velocity"] = {"figure": str(fig2), "data": str(data2)}
    return doc, lines


def _demo_capstan(dev, outputs: _Outputs):
    from tendyn.pipelines.capstan_demo import blocked_link_demo

    _DEMO_STEP(f"blocked-link tests on the {dev.name} twin")
    demo = blocked_link_demo(dev)
    fig, data = outputs.save(demo, "blocked_link")
    lines = [f"{name}: torque/angle slope {k:.3f} N·m/rad (motor side)" for name, k in demo.stiffness_motor.items()]
    lines.append(f"figure: {fig}")
    return {"device": dev.name, "figure": str(fig), "data": str(data),
            "stiffness_motor_Nm_rad": demo.stiffness_motor}, lines


def _demo_bench(bench, outputs: _Outputs):
    """Open-loop FRF at several amplitudes vs the analytic plant (S1, C22)."""
    from tendyn.pipelines.bench_frf import bench_frf

    _DEMO_STEP(f"stepped sines on the {bench.name} twin at 4 amplitudes")
    frf = bench_frf(bench)
    fig, data = outputs.save(frf, "bench_frf_amplitudes")
    peaks = frf.peaks_hz()
    lines = [f"input {a:.2f} N: open-loop resonance peak at {f:.0f} Hz" for a, f in peaks.items()]
    lines.append(f"figure: {fig}")
    return {"device": bench.name, "figure": str(fig), "data": str(data),
            "peak_hz": {str(a): f for a, f in peaks.items()}}, lines


# ---- entry point ----------------------------------------------------------------------------------

class _TerminalText:
    """stdout on a terminal: every write shown without control characters (:func:`tendyn.text.printable`; newline,
    tab and carriage return kept), so no text from a file (a name, a path, a log's meta) can drive the terminal.
    A pipe or a file gets the bytes unchanged."""

    def __init__(self, stream):
        from tendyn.text import printable

        self._stream, self._printable = stream, printable

    def write(self, text: str) -> int:
        self._stream.write(self._printable(text, keep="\n\t\r"))
        return len(text)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def _terminal_stdout():
    stream = sys.stdout
    tty = False
    try:
        tty = stream.isatty()
    except (AttributeError, ValueError):
        pass
    if not tty:
        yield
        return
    sys.stdout = _TerminalText(stream)
    try:
        yield
    finally:
        if isinstance(sys.stdout, _TerminalText):
            sys.stdout = stream


def _quiet_stdout() -> None:
    """After a closed pipe: point stdout at /dev/null so the interpreter's final flush stays silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


def _config_parser() -> argparse.ArgumentParser:
    """The parser of `tendyn config` alone: answers in milliseconds (no numpy, no device or simulator module)."""
    from tendyn.commands import config

    p = _Parser(prog="tendyn")
    config.register(p.add_subparsers(dest="command", required=True, parser_class=_Parser))
    return p


def _error_kind(exc: BaseException) -> str | None:
    """"input" (exit 2: UsageError, DeviceError, LogError), "check" (exit 1: CheckFailed, SimulationDiverged: a run
    that diverged in any command) or None. The classes are looked up only in the modules already imported, so
    that the command line loads nothing for its error handling (an exception of a module never imported cannot
    have been raised)."""
    def classes(*where):
        return tuple(getattr(sys.modules[m], n) for m, n in where if m in sys.modules)

    if isinstance(exc, (UsageError,) + classes(("tendyn.device.schema", "DeviceError"), ("tendyn.io.logs", "LogError"))):
        return "input"
    if isinstance(exc, (CheckFailed,) + classes(("tendyn._core", "SimulationDiverged"))):
        return "check"
    return None



def _interrupt_is_exit_130(run):
    """Ctrl-C is exit 130 wherever it lands: also while an error is being reported and, for the process's own
    command line (``argv`` None), after the command has returned. There the process ends itself: exit handlers
    run with Ctrl-C meaning exit 130, then ``os._exit`` — the interpreter's own teardown would restore the default
    SIGINT action first, and a Ctrl-C in it killed the process by the signal (status -2, not 130)."""
    import functools

    @functools.wraps(run)
    def guarded(argv: list[str] | None = None) -> int:
        try:
            code = run(argv)
        except KeyboardInterrupt:
            print("tendyn: interrupted", file=sys.stderr)
            code = 130
        if argv is not None:
            return code
        import atexit
        import signal
        import threading

        if threading.current_thread() is not threading.main_thread():
            return code
        if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:     # an ignore inherited (background job) stays
            signal.signal(signal.SIGINT, _exit_130)
        if code == 130:
            # after a Ctrl-C the exit handlers close what the interrupt left half-built, and some cannot: Dask's
            # close_clusters on a local cluster interrupted while its workers started raises AssertionError
            # (Status.init), which the interpreter printed as a traceback after "tendyn: interrupted". Their
            # failures are not reported then: the one line stands (the worker processes still end with us).
            sys.unraisablehook = lambda unraisable: None
        try:
            atexit._run_exitfuncs()             # what the interpreter's exit would run (finalizers, flushes)
            sys.stdout.flush()
            sys.stderr.flush()
        except BrokenPipeError:
            pass
        finally:
            os._exit(code)
    return guarded


def _exit_130(signum, frame) -> None:
    """SIGINT after the command returned: every output is already whole; flush and exit 130 at once."""
    try:
        sys.stdout.flush()
        print("tendyn: interrupted", file=sys.stderr, flush=True)
    finally:
        os._exit(130)


@_interrupt_is_exit_130
def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    os.environ["TENDYN_DEBUG"] = "1" if debug else ""   # tendyn.progress.debugging(): Dask's warnings shown
    command = next((a for a in argv if not a.startswith("-")), "tendyn")
    try:
        if argv[:1] == ["config"]:
            parser = _config_parser()
        else:
            if any(_NEGATIVE_VALUE.match(a) for a in argv):     # the catalogue (numpy) only when it matters
                from tendyn.sim import catalogue

                argv = _join_negative_values(argv, {flag(k) for k in catalogue.OPTIONS})
            parser = _main_parser()
        args = parser.parse_args(argv)
        with _terminal_stdout():
            code = args.func(args)
        sys.stdout.flush()
        return code
    except KeyboardInterrupt:
        print("tendyn: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        _quiet_stdout()
        return 0
    except Exception as exc:  # noqa: BLE001 — the one place that turns a bug into one clear line
        if _name_too_long(exc):                 # a path argument longer than the file system allows: input
            print(f"tendyn: error: {_one_line(exc)}", file=sys.stderr)
            return 2
        kind = _error_kind(exc)
        if kind == "input":
            print(f"tendyn: error: {_one_line(exc)}", file=sys.stderr)
            return 2
        if kind == "check":
            print(f"tendyn: check failed: {_one_line(exc)}", file=sys.stderr)
            return 1
        if debug:
            import traceback

            traceback.print_exc()
        hint = "" if debug else " (run again with --debug for the traceback)"
        print(f"tendyn: internal error in `{command}`: {type(exc).__name__}: {_one_line(exc)}{hint}",
              file=sys.stderr)
        return 3


def _name_too_long(exc: BaseException) -> bool:
    """An OSError of a path given on the command line (or a file inside it) that is longer than the file system
    allows (ENAMETOOLONG): wherever it is first touched (an existence check, a read, a write probe), it is the
    user's input, not a bug."""
    import errno

    return isinstance(exc, OSError) and exc.errno == errno.ENAMETOOLONG


def _one_line(exc: BaseException) -> str:
    """The message on one line, its control characters shown as escapes (a file or folder name can hold any)."""
    from tendyn.text import printable

    return printable(" ".join(str(exc).split()))


if __name__ == "__main__":
    sys.exit(main())
