"""Private timing of the simulator step (issue 12 item 2): old step (headers of a git ref, default ``main``)
vs this tree's, same driver, same model, interleaved in one session, thread CPU time, median of rounds.

    .venv/bin/python benchmarks/sim_step_profile.py [--ref main] [--rounds 7] [--device lexos]

Dumps the simulator model of the device (tendyn.sim.model.sim_model, 10 kHz, friction and sensors on) to
build/step_profile/, builds benchmarks/sim_step_driver.cpp twice through a scratch CMake project (the same
flags and Pinocchio as the package), runs old and new alternately, prints µs/step (median, min over the
rounds), the ratio and the largest difference between the two trajectories (q, qd every control period).
``--callgrind`` also runs each binary once under valgrind --tool=callgrind (1 simulated second) for the profile.
Not part of ``make bench`` (the benchmark entries are benchmarks/run.py's).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "build" / "step_profile"

CMAKE = """cmake_minimum_required(VERSION 3.18)
project(step_profile CXX)
set(CMAKE_CXX_STANDARD 17)
set(CMAKE_BUILD_TYPE Release)
set(CMAKE_CXX_FLAGS "${CMAKE_CXX_FLAGS} -g")  # line-level profiles; -g does not change the generated code
find_package(Python 3.9 COMPONENTS Interpreter REQUIRED)
execute_process(COMMAND "${Python_EXECUTABLE}" -m cmeel cmake OUTPUT_VARIABLE P OUTPUT_STRIP_TRAILING_WHITESPACE)
list(APPEND CMAKE_PREFIX_PATH "${P}")
find_package(Eigen3 REQUIRED CONFIG)
find_package(pinocchio REQUIRED CONFIG)
add_executable(driver_old @SRC@)
target_include_directories(driver_old PRIVATE @OLD@)
target_link_libraries(driver_old PRIVATE Eigen3::Eigen pinocchio::pinocchio)
add_executable(driver_new @SRC@)
target_include_directories(driver_new PRIVATE @NEW@)
target_link_libraries(driver_new PRIVATE Eigen3::Eigen pinocchio::pinocchio)
"""


def dump(device: str, rate_hz: float, scenario: str = "default") -> tuple[Path, Path]:
    from tendyn.device import compile_device, load_device
    from tendyn.devices import bundled
    from tendyn.sim.model import sim_model
    from tendyn import _core

    dev = load_device(bundled(device))
    cd = compile_device(dev)
    m = sim_model(dev, rate_hz=rate_hz, friction=True, sensors=True)
    lines = ["gravity " + " ".join(repr(float(x)) for x in dev.kinematics.gravity)]
    for f in cd.joint_frames:
        vals = [f.parent, *np.asarray(f.placement, float).ravel(), *np.asarray(f.axis, float), int(f.prismatic),
                f.mass, *np.asarray(f.com, float), *np.asarray(f.inertia, float).ravel()]
        lines.append("joint " + " ".join(repr(float(x)) for x in vals))
    L, c = cd.active_map
    L = np.asarray(L, float)
    lines.append(f"L {L.shape[0]} {L.shape[1]} " + " ".join(repr(float(x)) for x in L.ravel()))
    lines.append("c " + " ".join(repr(float(x)) for x in np.asarray(c, float)))
    for k in ("rotor_inertia", "torque_constant", "peak_torque", "encoder_counts", "current_noise"):
        lines.append(k + " " + " ".join(repr(float(x)) for x in np.asarray(getattr(m, k))))
    lines.append(f"dt {m.dt!r}")
    lines.append(f"control_decimation {m.control_decimation}")
    if scenario == "stickslip":  # benchmarks/sim_bench.py's test: gravity hold at Q0 + 0.02 N·m sines
        sys.path.insert(0, str(ROOT / "benchmarks"))
        import sim_bench

        q0 = sim_bench.Q0
        hold = sim_bench.test_inputs(cd, m, 1)[0]  # at t = 0 the sines are zero: the hold torques
        lines.append("hold " + " ".join(repr(float(x)) for x in hold))
        lines.append(f"amplitude {sim_bench.SINE_NM!r}")
    else:
        q0 = np.array([0.0, 0.3, 0.0, 0.8])[: m.na]
    lines.append("q0 " + " ".join(repr(float(x)) for x in q0))
    BUILD.mkdir(parents=True, exist_ok=True)
    model_txt, tr_path = BUILD / f"{device}.{scenario}.sim.txt", BUILD / f"{device}.model"
    model_txt.write_text("\n".join(lines) + "\n")
    _core.save_transmission_model(m.tendon, str(tr_path))
    return model_txt, tr_path


def build(ref: str) -> tuple[Path, Path]:
    old_inc = BUILD / f"include_{ref.replace('/', '_')}"
    subprocess.run(["rm", "-rf", str(old_inc)], check=True)
    old_inc.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "include"], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(old_inc)], input=archive, check=True)
    proj = BUILD / "proj"
    proj.mkdir(exist_ok=True)
    (proj / "CMakeLists.txt").write_text(CMAKE.replace("@SRC@", str(ROOT / "benchmarks" / "sim_step_driver.cpp"))
                                         .replace("@OLD@", str(old_inc / "include"))
                                         .replace("@NEW@", str(ROOT / "include")))
    out = BUILD / "bin"
    subprocess.run(["cmake", "-S", str(proj), "-B", str(out), f"-DPython_EXECUTABLE={sys.executable}"],
                   check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(out), "-j", "1"], check=True)
    return out / "driver_old", out / "driver_new"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ref", default="main")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--device", default="lexos")
    ap.add_argument("--rate", type=float, default=10_000.0)
    ap.add_argument("--callgrind", action="store_true")
    ap.add_argument("--scenario", choices=("default", "stickslip"), default="default",
                    help="stickslip: sim_bench.py's test (q0, gravity hold + 0.02 N·m sines); "
                         "set TENDYN_PROFILE_SECONDS=2 for its length")
    ap.add_argument("--no-build", action="store_true")
    a = ap.parse_args()
    model_txt, tr = dump(a.device, a.rate, a.scenario)
    if a.no_build:
        old, new = BUILD / "bin" / "driver_old", BUILD / "bin" / "driver_new"
    else:
        old, new = build(a.ref)
    times = {"old": [], "new": []}
    for name, exe in (("old", old), ("new", new)):  # trajectories (and a warm-up)
        r = subprocess.run([str(exe), str(model_txt), str(tr), "1", str(BUILD / f"traj_{name}.txt")],
                           check=True, capture_output=True, text=True)
        print(f"[{name}] {r.stderr.strip()}", file=sys.stderr)
    for k in range(a.rounds):
        for name, exe in (("old", old), ("new", new)) if k % 2 == 0 else (("new", new), ("old", old)):
            r = subprocess.run([str(exe), str(model_txt), str(tr), "3"], check=True, capture_output=True, text=True)
            times[name] += [float(x) for x in r.stdout.split()]
    to, tn = np.median(times["old"]), np.median(times["new"])
    print(f"old ({a.ref}): median {to:.3f} us/step, min {min(times['old']):.3f}  ({len(times['old'])} runs)")
    print(f"new (tree):  median {tn:.3f} us/step, min {min(times['new']):.3f}  ({len(times['new'])} runs)")
    print(f"ratio old/new: {to / tn:.2f} (median), {min(times['old']) / min(times['new']):.2f} (min)")
    A, B = np.loadtxt(BUILD / "traj_old.txt"), np.loadtxt(BUILD / "traj_new.txt")
    na = (A.shape[1] - 1) // 2
    for t_end in (0.1, 1.0, 2.0, 10.0):
        rows = A[:, 0] <= t_end + 1e-12
        dq = np.abs(A[rows, 1:1 + na] - B[rows, 1:1 + na]).max()
        dv = np.abs(A[rows, 1 + na:] - B[rows, 1 + na:]).max()
        print(f"trajectory difference up to t = {t_end:4.1f} s: |dq| {dq:.3e} rad, |dqd| {dv:.3e} rad/s")
    if a.callgrind:
        for name, exe in (("old", old), ("new", new)):
            outf = BUILD / f"callgrind.{name}"
            subprocess.run(["env", "TENDYN_PROFILE_SECONDS=1", "valgrind", "--tool=callgrind", f"--callgrind-out-file={outf}", str(exe), str(model_txt),
                            str(tr), "1"], check=True, capture_output=True)
            rep = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(outf)], capture_output=True, text=True)
            (BUILD / f"callgrind.{name}.txt").write_text(rep.stdout)
            print(f"[callgrind] {name}: {BUILD / f'callgrind.{name}.txt'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
