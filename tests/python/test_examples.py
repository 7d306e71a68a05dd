"""The numbered examples give the same numbers in C, C++ and Python (examples/), on any device: the bundled
L-EXOS and a 2-transmission planar arm generated here. The native programs are built against the INSTALLED
package (the venv's tendyn) as a user builds them: CMake, pkg-config and `tendyn config` (native_build.py)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from native_build import ROUTES, build, installed_package, run, user_env

REPO = Path(__file__).resolve().parents[2]
EX01 = REPO / "examples" / "01_feedforward"
EX02 = REPO / "examples" / "02_compensation"

MOTOR = """[transmissions.motor]
torque_constant = 0.08
rotor_inertia = 3e-5
continuous_torque = 0.5
peak_torque = 2.0
[transmissions.sensors]
encoder_counts = 8192
current_noise = 0.0
"""
PLANAR2 = """
schema = 1
[device]
name = "planar2"
[kinematics]
convention = "dh"
gravity = [0.0, -9.81, 0.0]
[[kinematics.joints]]
name = "shoulder"
a = 0.25
alpha = 0.0
d = 0.0
lower = -2.0
upper = 2.0
mass = 1.5
com = [-0.12, 0.01, 0.0]
inertia = [0.004, 0.012, 0.012, 0.0, 0.0, 0.0]
[[kinematics.joints]]
name = "elbow"
a = 0.2
alpha = 0.0
d = 0.0
lower = -2.5
upper = 2.5
mass = 0.7
com = [-0.09, 0.0, 0.0]
inertia = [0.002, 0.005, 0.005, 0.0, 0.0, 0.0]
[[transmissions]]
name = "t1"
joint = 1
motor_radius = 0.01
driven_radius = 0.05
reducer_ratio = 6.0
reducer_efficiency = 0.92
pretension = 40.0
friction = [{tau0 = 0.6, nu = 4.0, beta = 0.01}]
""" + MOTOR + """[[transmissions]]
name = "t2"
joint = 2
motor_radius = 0.009
crosses = [1]
crossed_radii = [-0.012]
driven_radius = 0.04
reducer_ratio = 5.0
reducer_efficiency = 0.88
pretension = 30.0
friction = [{tau0 = 0.4, nu = 3.0, beta = 0.015}, {tau0 = 0.3, nu = 2.0, beta = 0.02}]
bearings = [{}, {count = 2, radius = 0.012, wrap = 3.14159, static_coefficient = 0.002, dynamic_coefficient = 0.0015, h0 = 1e-4, h1 = 2e-5, n0 = 5.0}]
""" + MOTOR


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """Model files the examples read: L-EXOS's committed ones and a generated 2-transmission planar arm
    (with a crossed joint, reducers, β and bearings), exported by Python (Transmission / Compensator.export)."""
    from tendyn.control import Compensator
    from tendyn.device import load_device
    from tendyn.transmission import Transmission

    d = tmp_path_factory.mktemp("models")
    (d / "planar2.toml").write_text(PLANAR2)
    dev = load_device(d / "planar2.toml")
    Transmission.from_device(dev).export(d / "planar2.model")
    Compensator.from_device(dev).export(d / "planar2.comp")
    return {"lexos.model": EX01 / "lexos.model", "lexos.comp": EX02 / "lexos.comp", "planar2.toml": d / "planar2.toml",
            "planar2.model": d / "planar2.model", "planar2.comp": d / "planar2.comp"}


@pytest.fixture(scope="module", params=ROUTES)
def programs(request, tmp_path_factory):
    """The four native examples built against the installed package by one route (CMake, pkg-config,
    `tendyn config --cflags --libs`)."""
    installed_package()
    return build(request.param, tmp_path_factory.mktemp(request.param))


def _numbers(text: str) -> np.ndarray:
    line = next(ln for ln in text.splitlines() if ln.startswith("torque_motor"))
    return np.array([float(x) for x in line.split()[1:]])


def _python(script: Path, *args) -> str:
    return subprocess.run([sys.executable, str(script), *map(str, args)], capture_output=True, text=True,
                          check=True).stdout


@pytest.mark.parametrize("name", ["lexos.model", "planar2.model"])
def test_example_01_python_runs_and_matches_the_core(models, name):
    """The example's numbers against independent statics: joint i asks τ_i = 2/(i+1) N·m at q̇_i = 0.5/(i+1) rad/s.

    Lossless part (C3): C_m = R_m t with t from τ_J = Kᵀ t, solved here with numpy from the model file's
    routing. With losses the motors put in MORE power than the joints deliver (friction only takes), and the
    answer is not the lossless one. The example equals a direct call of the core on the device file (bit for
    bit: the model file reads back exactly), and its own device file gives the same numbers as its model file."""
    from tendyn.transmission import Transmission

    c = _numbers(_python(EX01 / "feedforward.py", models[name]))
    tr = Transmission.load(models[name])
    assert c.shape == (tr.n,)
    fields = tr.to_dict()
    K, r_m = fields["K"], fields["motor_radius"]
    i = np.arange(tr.n)
    tau, qd = 2.0 / (i + 1), 0.5 / (i + 1)
    lossless = r_m * np.linalg.solve(K.T, tau)
    qd_m = np.linalg.solve(np.diag(r_m), K @ qd)
    assert qd_m @ c > qd @ tau                       # power in > power out: the loss is positive
    assert not np.allclose(c, lossless, rtol=1e-3)
    np.testing.assert_array_equal(c, tr.feedforward(tau, qd).torque_motor)
    if name == "planar2.model":
        np.testing.assert_array_equal(c, _numbers(_python(EX01 / "feedforward.py", models["planar2.toml"])))


@pytest.mark.parametrize("name", ["lexos.model", "planar2.model", "planar2.comp"])
def test_example_01_same_numbers_in_c_cpp_python(programs, models, name):
    """Example 01 in C (C ABI) and C++ (header-only core) built against the installed package, on any model
    file (a compensator file too: its transmission comes first): equal to the Python example to 1e-14,
    run without LD_LIBRARY_PATH (the rpath finds libtendyn_c)."""
    py = _numbers(_python(EX01 / "feedforward.py", models[name]))
    for exe in (programs["feedforward_c"], programs["feedforward_cpp"]):
        native = _numbers(run([str(exe), str(models[name])], env=user_env()))
        assert native.shape == py.shape
        np.testing.assert_allclose(native, py, rtol=1e-14, atol=0)


def test_example_01_model_file_is_exported_from_lexos_toml(tmp_path):
    """The C and C++ examples load examples/01_feedforward/lexos.model (no hand-copied numbers): it must be
    what Python exports from the bundled lexos.toml today. Regenerate with
    ``Transmission.from_device(load_device(bundled("lexos"))).export("examples/01_feedforward/lexos.model")``."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.transmission import Transmission

    fresh = tmp_path / "lexos.model"
    Transmission.from_device(load_device(bundled("lexos"))).export(fresh)
    committed = REPO / "examples" / "01_feedforward" / "lexos.model"
    assert committed.read_text() == fresh.read_text(), "lexos.model is stale: re-export it (see the docstring)"


# ---- example 02: compensation cycles on an exported compensator model ---------------------------------------

def _lines(text: str) -> dict:
    return {ln.split()[0]: np.array([float(x) for x in ln.split()[1:]])
            for ln in text.splitlines() if ln and not ln.startswith("#")}


@pytest.mark.parametrize("name", ["lexos.comp", "planar2.comp"])
def test_example_02_same_numbers_in_c_cpp_python(programs, models, name):
    """Example 02 in C, C++ (both built against the installed package) and Python on any compensator file:
    equal to 1e-12, n from the file."""
    py = _lines(_python(EX02 / "compensation.py", models[name]))
    assert set(py) == {"torque_motor", "sum_torque_motor"}
    assert len(py["torque_motor"]) == {"lexos.comp": 4, "planar2.comp": 2}[name]
    for exe in (programs["compensation_c"], programs["compensation_cpp"]):
        native = _lines(run([str(exe), str(models[name])], env=user_env()))
        for key in py:
            np.testing.assert_allclose(native[key], py[key], rtol=1e-12, atol=1e-12)


def test_example_02_refuses_another_devices_file(programs, models):
    """Given the device it expects, the C example refuses another device's compensator file (exit 1, the file
    and the field named); the Python example too."""
    r = subprocess.run([str(programs["compensation_c"]), str(models["planar2.comp"]), "L-EXOS"],
                       capture_output=True, text=True, env=user_env())
    assert r.returncode == 1 and "planar2.comp" in r.stderr and "device" in r.stderr, r.stderr
    r = subprocess.run([sys.executable, str(EX02 / "compensation.py"), str(models["planar2.comp"]), "L-EXOS"],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "device" in r.stderr


def test_example_02_model_file_is_exported_from_lexos_toml(tmp_path):
    """examples/02_compensation/lexos.comp is what Python exports from the bundled lexos.toml today
    (regenerate: ``python examples/02_compensation/compensation.py --export``)."""
    from tendyn.control import Compensator
    from tendyn.device import load_device
    from tendyn.devices import bundled

    fresh = tmp_path / "lexos.comp"
    Compensator.from_device(load_device(bundled("lexos"))).export(fresh)
    assert (EX02 / "lexos.comp").read_text() == fresh.read_text(), "lexos.comp is stale: re-export it"


def test_example_03_tx40_identification_runs():
    """Example 03 identifies the real TX40 from the measured data shipped with the package (tendyn data path tx40,
    the same bytes as the shared copy)."""
    out = subprocess.run([sys.executable, str(REPO / "examples/03_tx40_identification/identify_tx40.py")],
                         capture_output=True, text=True, check=True).stdout
    assert "base parameters (OLS)" in out and "base parameters (WLS)" in out
    assert "ZZ1R" in out and "cross-validation (first half -> second half)" in out
