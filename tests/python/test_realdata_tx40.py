"""TX40 against FIGAROH (issue 29): ``--treatment figaroh`` reproduces every parameter FIGAROH determines
(%σ < 5, TX40_bp_5.csv, OLS and WLS) — the target is 2 %, measured 0.006 %, asserted 0.1 % so that each of
FIGAROH's quirks the preset reproduces is seen when left out (each moves a parameter by about 1 %); the change of
parametrization of the coupled wrist; the split of the log (docs/realdata.md).

Needs ../shared/external-data/staubli_tx40 (or TENDYN_SHARED); skipped with the reason when absent. The preset's
treatment of the full log takes ~3 s (a full-rate 270 000-row regressor and scipy's decimate on each column),
once per module; the plants are behind ``slow`` (the same code path as the reproduction test).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("TENDYN_SHARED") or ROOT.parent / "shared")
REF = SHARED / "external-data" / "staubli_tx40" / "reference" / "TX40_bp_5.csv"
pytestmark = pytest.mark.skipif(not REF.is_file(), reason=f"the TX40 data and FIGAROH's results are absent ({REF})")


@pytest.fixture(scope="module")
def tx40():
    path = ROOT / "benchmarks" / "realdata" / "tx40.py"
    spec = importlib.util.spec_from_file_location("realdata_test_tx40", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def log(tx40):
    return tx40.load(SHARED)


@pytest.fixture(scope="module")
def names(tx40):
    from tendyn.ident.estimate import cached_model

    return list(cached_model(tx40.device()).base.names)


def _worst(tx40, names, obs):
    """Largest |relative difference| [%] over the parameters FIGAROH determines (%σ < 5), OLS and WLS."""
    ref = tx40.reference(SHARED)
    worst = 0.0
    for method, col in (("ols", 0), ("wls", 2)):
        fig = tx40.figaroh_values(names, tx40.solve(obs, method))
        for n, v in zip(names, fig):
            if ref[n][col + 1] < 5.0:
                worst = max(worst, abs(100 * (v / ref[n][col] - 1)))
    return worst


def test_reference_names_are_tendyn_base_parameters(tx40, names):
    ref = tx40.reference(SHARED)
    assert set(ref) == set(names) and len(ref) == 60
    assert sum(r[1] < 5.0 for r in ref.values()) == 19 and sum(r[3] < 5.0 for r in ref.values()) == 19


def test_parametrization_round_trip_and_what_it_moves(tx40, names):
    rng = np.random.default_rng(0)
    x = rng.normal(size=len(names))
    np.testing.assert_allclose(tx40.tendyn_values(names, tx40.figaroh_values(names, x)), x, rtol=1e-12, atol=1e-12)
    d = dict(zip(names, tx40.figaroh_values(names, x)))
    src = dict(zip(names, x))
    assert d["FV5"] == pytest.approx(src["FV5"] + 1024 * src["FVm6"]) and d["FSm6"] == pytest.approx(32 * src["FSm6"])
    assert d["ZZ1R"] == src["ZZ1R"]


@pytest.fixture(scope="module")
def preset_obs(tx40, log):
    return tx40.preset_observations(log)


def test_figaroh_preset_reproduces_every_determined_parameter(tx40, names, preset_obs):
    assert _worst(tx40, names, preset_obs) < 0.1          # target 2 %; measured 0.006 % (FIGAROH rounds to 1e-6)
    assert "treatment figaroh" in preset_obs[0].treatment_.describe()


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["last acceleration computed", "blocks aligned", "cut-off as a -3 dB zero-phase"])
def test_figaroh_preset_plants_are_seen(tx40, names, log, monkeypatch, plant):
    import tendyn.ident.treatment as treatment

    if plant == "last acceleration computed":
        monkeypatch.setattr(treatment, "FIGAROH_LAST_ACCELERATION", True)
    elif plant == "blocks aligned":
        monkeypatch.setattr(treatment, "FIGAROH_BLOCK_SHIFT", False)
    else:                         # FIGAROH's 100 Hz read as tendyn's zero-phase -3 dB cut-off at 100 / 4 Hz
        fields = treatment.PRESETS["figaroh"].fields
        monkeypatch.setitem(treatment.PRESETS, "figaroh", treatment.Preset(
            "planted", lambda r, b: dict(fields(r, b), cutoff_hz=treatment.zero_phase_cutoff_of_design(
                fields(r, b)["cutoff_hz"], r, 4) * 1.5)))
    assert _worst(tx40, names, tx40.preset_observations(log)) > 0.1


def test_split_default_predicts_the_unseen_half_better_than_figaroh_method(tx40, log):
    """Fitted on the first half, predicting the second: tendyn's defaults beat FIGAROH's script fitted on the same
    half (8.6 % vs 15.2 %); FIGAROH's published parameters, which saw the second half, reach 6.3 %."""
    fit_p, test_p = tx40.SPLITS["second half (fit on the first)"]
    test = tx40.observations(log, test_p)
    default = tx40.relative_error(test, tx40.solve(tx40.observations(log, fit_p)))[0]
    method = tx40.relative_error(test, tx40.solve(tx40.preset_observations(log, fit_p)))[0]
    assert default < 0.6 * method
    assert 0.06 < default < 0.095


def test_equal_footing_default_on_the_whole_log_at_least_as_good_on_each_half(tx40, log, names):
    """Given what FIGAROH's published parameters saw (the whole log), tendyn's default fit of the whole log predicts
    each half at least as well: measured 6.23 / 5.83 % against 6.31 / 5.85 % (both in-sample: not the issue's
    unseen-part target, which stays an expected failure below). Plants measured: the velocity threshold 0 fails it
    (6.74 / 6.42 %), so does WLS on the second half (6.39 %); the cut-off read as rad/s (314 Hz) does not
    (6.23 / 5.84 %: the parallel filter, not the position filter, sets the band)."""
    ref = tx40.reference(SHARED)
    published = tx40.tendyn_values(names, [ref[n][0] for n in names])
    whole = tx40.solve(tx40.observations(log))
    for fit_p, test_p in tx40.SPLITS.values():
        test = tx40.observations(log, test_p)
        assert tx40.relative_error(test, whole)[0] <= tx40.relative_error(test, published)[0]


@pytest.mark.xfail(strict=True, reason="FIGAROH's published parameters were fitted on the whole log, the unseen "
                                       "half included: 6.31 % / 5.85 % against tendyn's 8.56 % / 7.87 % fitted on "
                                       "the other half (WLS 8.14 / 7.45, consistent 8.10 / 7.77, WLS + consistent "
                                       "7.93 / 7.45, essential 7.93 / 7.99; interleaved blocks of 0.25-3 s: tendyn "
                                       "9-62 % above); on equal footing (tendyn also fitted on the whole log) "
                                       "6.23 / 5.83 %: docs/realdata.md")
def test_split_default_at_least_as_good_as_the_published_parameters(tx40, log, names):
    ref = tx40.reference(SHARED)
    published = tx40.tendyn_values(names, [ref[n][0] for n in names])
    fit_p, test_p = tx40.SPLITS["second half (fit on the first)"]
    test = tx40.observations(log, test_p)
    assert tx40.relative_error(test, tx40.solve(tx40.observations(log, fit_p)))[0] <= \
        tx40.relative_error(test, published)[0]


def test_identify_cli_takes_the_figaroh_preset(tx40, log, tmp_path, capsys):
    import json

    from tendyn.cli import main
    from tendyn.io import make_log, write_log

    short = make_log({k: v[:15000] for k, v in log.columns.items()}, device="tx40", rate_hz=log.meta["rate_hz"],
                     seed=None, experiment="exciting")                  # the first 3 s: the option, not the numbers
    path = write_log(short, tmp_path / "tx40.parquet")
    assert main(["identify", "tx40", str(path), "--treatment", "figaroh", "--json", "--quiet"]) == 0
    out = capsys.readouterr()
    doc = json.loads(out.out)
    assert doc["treatment"]["preset"] == "figaroh" and doc["treatment"]["decimate"] == 100
    assert "treatment figaroh" in out.err
