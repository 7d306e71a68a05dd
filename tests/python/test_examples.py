"""The numbered examples give the same numbers in C, C++ and Python (examples/)."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BUILT = REPO / "build" / "cpp" / "examples"


def _numbers(text: str) -> np.ndarray:
    line = next(ln for ln in text.splitlines() if ln.startswith("torque_motor"))
    return np.array([float(x) for x in line.split()[1:]])


def test_example_01_python_runs_and_matches_the_core():
    """The example's numbers, checked against the statics of the bundled L-EXOS by hand where they are
    simple: the example asks τ = (2, 0, 0, 1) N·m at q̇ = (0.5, 0, 0, 0.2) rad/s.

    Lossless part (C3): C_m = R_m t with t from τ_J = Kᵀ t, solved here with numpy from the routing.
    With losses every moving transmission needs MORE motor torque than lossless (power flows from the
    motors and friction only takes), and transmissions 2 and 3, whose joints and motors are at rest or
    carry no load of their own, still pass the coupling torques. Finally the example equals a direct call
    of the core with the same inputs (bit for bit)."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.transmission import Transmission

    out = subprocess.run([sys.executable, str(REPO / "examples/01_feedforward/feedforward.py")],
                         capture_output=True, text=True, check=True).stdout
    c = _numbers(out)
    assert c.shape == (4,)
    dev = load_device(bundled("lexos"))
    arr = dev.routing_arrays()
    K, r_m = arr["K"], arr["motor_radius"]
    tau, qd = np.array([2.0, 0.0, 0.0, 1.0]), np.array([0.5, 0.0, 0.0, 0.2])
    lossless = r_m * np.linalg.solve(K.T, tau)
    qd_m = np.linalg.solve(np.diag(r_m), K @ qd)
    # power in ≥ power out (the loss is positive), and the example is not the lossless answer
    assert qd_m @ c > qd @ tau
    assert not np.allclose(c, lossless, rtol=1e-3)
    # each loaded, driving transmission asks more than lossless: 1 and 4 carry τ and move with it
    assert c[0] > lossless[0] > 0 and c[3] > lossless[3] > 0
    core = Transmission.from_device(dev).feedforward(tau, qd).torque_motor
    np.testing.assert_array_equal(c, core)


def test_example_01_same_numbers_in_c_cpp_python():
    exes = [BUILT / "example_01_feedforward_c", BUILT / "example_01_feedforward_cpp"]
    if not all(e.exists() for e in exes):
        if os.environ.get("TENDYN_REQUIRE_EXAMPLES"):
            pytest.fail(f"examples not built in {BUILT} (make test builds them first)")
        pytest.skip("C/C++ examples not built (run `make test`)")
    py = _numbers(subprocess.run([sys.executable, str(REPO / "examples/01_feedforward/feedforward.py")],
                                 capture_output=True, text=True, check=True).stdout)
    for exe in exes:
        env = dict(os.environ, LD_LIBRARY_PATH=str(REPO / "build" / "cpp"))
        native = _numbers(subprocess.run([str(exe)], capture_output=True, text=True, check=True, env=env).stdout)
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


# ---- example 02: compensation cycles on the exported L-EXOS model ------------------------------------------

EX02 = REPO / "examples" / "02_compensation"


def _lines(text: str) -> dict:
    return {ln.split()[0]: np.array([float(x) for x in ln.split()[1:]])
            for ln in text.splitlines() if ln and not ln.startswith("#")}


def test_example_02_same_numbers_in_c_cpp_python():
    """Example 02 in C, C++ (both built against the installed package) and Python: equal to 1e-12."""
    exes = [BUILT / "example_02_compensation_c", BUILT / "example_02_compensation_cpp"]
    if not all(e.exists() for e in exes):
        if os.environ.get("TENDYN_REQUIRE_EXAMPLES"):
            pytest.fail(f"example 02 not built in {BUILT} (make test builds it against the installed package)")
        pytest.skip("C/C++ example 02 not built (run `make test`)")
    py = _lines(subprocess.run([sys.executable, str(EX02 / "compensation.py")],
                               capture_output=True, text=True, check=True).stdout)
    assert set(py) == {"torque_motor", "sum_torque_motor"}
    for exe in exes:
        native = _lines(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout)
        for key in py:
            np.testing.assert_allclose(native[key], py[key], rtol=1e-12, atol=1e-12)


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
    """Example 03 identifies the real TX40 from the shared measured data (skipped only if they are absent)."""
    data = REPO.parent / "shared" / "external-data" / "staubli_tx40"
    if not data.is_dir():
        pytest.skip(f"the shared measured data are absent: {data}")
    out = subprocess.run([sys.executable, str(REPO / "examples/03_tx40_identification/identify_tx40.py")],
                         capture_output=True, text=True, check=True).stdout
    assert "base parameters (OLS)" in out and "base parameters (WLS)" in out
    assert "ZZ1R" in out and "cross-validation (first half -> second half)" in out
