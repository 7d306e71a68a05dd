"""What `make test` selects (issue 39, docs/testing.md): tests marked ``slow`` are deselected unless ``-m`` names the
marker, and each of them has a fast twin of the same code path that `make test` runs. Collected in a child pytest
(``--collect-only``: nothing runs), from a folder outside the repository."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

SLOW_FILE = HERE / "test_file_fuzz.py"
SLOW_TEST = "test_corrupted_input_files_never_crash_long"
FAST_TEST = "test_corrupted_input_files_never_crash"

FAST_TWINS = {
    "test_pip_alone.py::test_pip_wheel_installs_into_a_fresh_venv_and_runs_the_cli_and_the_c_example":
        "test_package.py::test_relocated_package_builds_by_its_own_paths",   # + `make test`'s own `pip install .`
    "test_cli_domain_fuzz.py::test_every_declared_domain_is_fuzzed_long":
        "test_cli_domain_fuzz.py::test_every_declared_domain_is_fuzzed",
    "test_cli_property_fuzz.py::test_every_command_fuzzed_long":
        "test_cli_property_fuzz.py::test_every_command_fuzzed_exit_codes_one_line_nothing_written",
    "test_file_fuzz.py::test_corrupted_input_files_never_crash_long":
        "test_file_fuzz.py::test_corrupted_input_files_never_crash",
    "test_report_hostile.py::test_slow_pages_are_inert": "test_report_hostile.py::test_every_page_shows_hostile_text_as_text",
    "test_design.py::test_sweep_and_identify_on_a_real_scheduler_equal_in_process":
        "test_design.py::test_campaigns_on_a_real_scheduler_equal_in_process",
    "test_realdata_mtm.py::test_wpi_published_parameters_plants_are_seen":
        "test_realdata_mtm.py::test_wpi_published_parameters_through_tendyn_within_5_percent",
    "test_realdata_mtm.py::test_preset_with_wpi_boxes_converged_is_far_from_wpi":   # + `make realdata`
        "test_realdata_mtm.py::test_wpi_preset_close_to_wpi",
    "test_realdata_mtm.py::test_wpi_preset_with_wpi_solver_within_5_percent":      # + `make scs126`
        "test_realdata_mtm.py::test_wpi_sdp_is_wpi_problem_shape",
    "test_realdata_tx40.py::test_figaroh_preset_plants_are_seen":
        "test_realdata_tx40.py::test_figaroh_preset_reproduces_every_determined_parameter",
    "test_blockmodel_amplitude.py::test_constant_level_misses_the_generated_bench":
        "test_blockmodel_amplitude.py::test_tension_model_holds_across_amplitudes_on_a_generated_bench",
    "test_blockmodel_amplitude.py::test_push_pull_model_across_amplitudes_on_generated_benches":
        "test_blockmodel_amplitude.py::test_tension_model_holds_across_amplitudes_on_a_generated_bench",
    "test_parallelogram_compensation.py::test_fig7_on_more_arms":
        "test_parallelogram_compensation.py::test_fig7_on_a_generated_arm_halves_the_hand_torque_and_stays_passive",
    # parameters (``pytest.param(..., id=ID, marks=pytest.mark.slow)``): file::[ID]
    "test_any_device.py::[n6-spatial-bearings]": "test_any_device.py::[n3-spatial-bearings]",
    "test_any_device.py::[demo-n6-planar]": "test_any_device.py::[demo-n3-spatial-bearings]",
    "test_any_device.py::[demo-n6-spatial-bearings]": "test_any_device.py::[demo-n3-spatial-bearings]",
    "test_parallelogram_twin.py::[arm1]": "test_parallelogram_twin.py::[arm0]",
    "test_parallelogram_twin.py::[arm2]": "test_parallelogram_twin.py::[arm0]",
}
"""slow test → the fast test of the same code path that `make test` runs. A slow test without one is not marked
(docs/testing.md lists both)."""


def _collected(tmp_path, *args) -> list[str]:
    r = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                        "-p", "no:randomly", *args, str(SLOW_FILE)], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return [line.split("::")[-1] for line in r.stdout.splitlines() if "::" in line], r.stdout


def test_slow_tests_are_deselected_unless_asked(tmp_path):
    """A plain run (what `make test` starts) collects the fast test and deselects the slow one; ``-m slow`` collects
    the slow one alone."""
    plain, out = _collected(tmp_path)
    assert FAST_TEST in plain and SLOW_TEST not in plain, out
    assert "1 deselected" in out, out
    asked, out = _collected(tmp_path, "-m", "slow")
    assert asked == [SLOW_TEST], out


def _param_id(node) -> str | None:
    """The ``id=`` of a ``pytest.param(...)`` call node, else None."""
    if isinstance(node, ast.Call) and ast.unparse(node.func).endswith("param"):
        for kw in node.keywords:
            if kw.arg == "id" and isinstance(kw.value, ast.Constant):
                return kw.value.value
    return None


def _slow_tests() -> set[str]:
    """file::name of every test function of tests/python decorated ``@pytest.mark.slow``, and file::[ID] of every
    ``pytest.param(..., id=ID, marks=pytest.mark.slow)`` (read from the source)."""
    found = set()
    for path in sorted(HERE.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.FunctionDef) and any(      # the mark itself, not a parametrize holding one
                    ast.unparse(d).endswith("mark.slow") for d in node.decorator_list):
                found.add(f"{path.name}::{node.name}")
            elif _param_id(node) is not None and any(
                    kw.arg == "marks" and "mark.slow" in ast.unparse(kw.value) for kw in node.keywords):
                found.add(f"{path.name}::[{_param_id(node)}]")
    return found


def _param_ids(path: Path) -> set[str]:
    """The ids of every ``pytest.param(..., id=ID)`` of a test file."""
    return {i for node in ast.walk(ast.parse(path.read_text("utf-8"))) if (i := _param_id(node)) is not None}


def test_every_slow_test_names_a_fast_twin_that_exists_and_is_not_slow():
    """Issue 39: a slow variant may leave `make test` only where a fast test still runs the same code path. Each
    slow test is listed here with its twin; the twin exists and is not marked slow itself."""
    slow = _slow_tests()
    assert slow == set(FAST_TWINS), (sorted(slow - set(FAST_TWINS)), sorted(set(FAST_TWINS) - slow))
    for twin in FAST_TWINS.values():
        file, name = twin.split("::")
        if name.startswith("["):       # a parameter of the same file
            assert name[1:-1] in _param_ids(HERE / file), twin
        else:
            assert f"def {name}(" in (HERE / file).read_text("utf-8"), twin
        assert twin not in slow, twin
