"""The validation figures (docs/figures): a quick run through the command line, its files, and its numbers
recomputed with the library and compared with Stable32's tables, theory and the ITU-T masks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner
from _helpers import assert_close_printed, read_stable32_table

import chronofuse.analysis.stability as st
from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.metrics import pooled_oadev
from chronofuse.analysis.theory import adev_theory
from chronofuse.cli.main import app
from chronofuse.experiments import validation
from chronofuse.models.oscillator_presets import PRESETS
from chronofuse.validation import InputError

PNGS = [
    "gps_deviations.png",
    "gps_tdev.png",
    "receiver_calibration.png",
    *[f"oscillator_{name}.png" for name in sorted(PRESETS)],
    "cs5071a_mtie.png",
    "cs5071a_tdev.png",
]


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory, data_dir):
    out = tmp_path_factory.mktemp("validation")
    result = CliRunner().invoke(app, ["validate", "--data", str(data_dir), "--out", str(out), "--quick"])
    assert result.exit_code == 0, result.output
    return out, json.loads((out / "validation.json").read_text())


def test_quick_run_writes_every_figure_as_a_png_and_the_json(quick_run):
    out, numbers = quick_run
    for name in PNGS:
        head = (out / name).read_bytes()[:8]
        assert head == b"\x89PNG\r\n\x1a\n", name
    assert numbers["quick"] is True
    assert set(numbers) >= {"gps", "receiver", "oscillators", "cs5071a", "settings", "seconds"}


def test_gps_numbers_are_the_library_values_and_equal_stable32_to_printed_precision(quick_run, data_dir):
    _, numbers = quick_run
    gps = data_dir / "stability" / "gps"
    x = np.loadtxt(gps / "gps_1pps_phase_data.txt.gz")
    for name, table_name in (("adev", "stable32_ADEV_decade.txt"), ("mdev", "stable32_MDEV_octave.txt"),
                             ("tdev", "stable32_TDEV_octave.txt")):
        table = read_stable32_table(gps / table_name)
        plotted = numbers["gps"]["ours"][name]
        np.testing.assert_array_equal(plotted["tau"], table["tau"])
        np.testing.assert_allclose(plotted["dev"], st.compute(name, x, 1.0, table["tau"]).dev, rtol=1e-12)
        np.testing.assert_allclose(numbers["gps"]["stable32"][name]["dev"], table["dev"], rtol=0)
        assert_close_printed(plotted["dev"], table["dev"], name=name)
        np.testing.assert_array_equal(plotted["n"], table["n"])
    mtot = numbers["gps"]["ours"]["mtotdev"]
    assert max(mtot["tau"]) == validation.QUICK.mtotdev_max_tau_s
    np.testing.assert_allclose(mtot["dev"], st.mtotdev(x, 1.0, np.array(mtot["tau"])).dev, rtol=1e-12)


def test_simulated_open_sky_receiver_follows_the_gps_record_and_raw_pps_keeps_the_sawtooth(quick_run):
    _, numbers = quick_run
    rec = numbers["receiver"]
    tau = np.array(rec["tau"])
    short = tau <= 100.0
    # 2e4 s simulated: at tau <= 100 s at least 200 Allan terms, so a 15 % band is several sigma wide.
    np.testing.assert_allclose(np.array(rec["ratio_sim_to_stable32"])[short], 1.0, atol=0.15)
    # A 48 MHz sawtooth (rms 6.0 ns) on top of 6.1 ns ADEV(1 s): the raw 1PPS is about twice as noisy.
    assert 1.6 < rec["ratio_raw_to_corrected"][0] < 2.2


def test_gps_record_behaves_like_a_qerr_corrected_pps_and_the_open_sky_preset_fits_it(quick_run):
    record = quick_run[1]["receiver"]["record"]
    # Gaussian second differences (Pearson kurtosis 3); an i.i.d. uniform sawtooth would give 2.4.
    assert 2.85 < record["kurtosis_second_difference"] < 3.1
    # White noise alone would give a lag-1 correlation of the first difference of -1/2.
    assert -0.5 < record["lag1_correlation_first_difference"] < -0.35
    # The preset is the docstring's least-squares fit: within 5 % of Stable32's OADEV up to 8192 s.
    assert record["analytic_worst_misfit"] < 0.05
    assert len(record["analytic_to_oadev_table_tau"]) == 14


def test_oscillator_theory_curves_are_adev_theory_and_short_tau_simulation_matches_them(quick_run):
    _, numbers = quick_run
    for name, model in PRESETS.items():
        osc = numbers["oscillators"][name]
        tau = np.array(osc["tau"])
        np.testing.assert_allclose(osc["theory"], adev_theory(model.h, tau, 1.0, model.drift_per_s), rtol=1e-12)
        lo, dev, hi = (np.array(osc[k]) for k in ("lo", "oadev", "hi"))
        assert np.all((lo < dev) & (dev < hi))
        # 2 x 2e4 s pooled: at tau <= 64 s thousands of degrees of freedom, a few percent at most.
        np.testing.assert_allclose(np.array(osc["ratio_sim_to_theory"])[tau <= 64], 1.0, atol=0.05)


def test_cs5071a_mask_limits_and_verdicts_are_the_library_ones(quick_run, data_dir):
    _, numbers = quick_run
    cs = data_dir / "stability" / "Cs5071A"
    x = np.loadtxt(cs / "5071A_phase.txt.gz")
    for metric, table_name in (("mtie", "mtie_decade.txt"), ("tdev", "tdev_decade.txt")):
        table = read_stable32_table(cs / table_name)
        dev = st.compute(metric, x, 1.0, table["tau"])
        plotted = numbers["cs5071a"][metric]
        np.testing.assert_allclose(plotted["ours"]["dev"], dev.dev, rtol=1e-12)
        assert_close_printed(plotted["ours"]["dev"], table["dev"], name=metric)
        for clock in ("prtc-a", "prtc-b", "g811"):  # the primary reference clocks the figures draw
            masks = MASKS[clock]
            result = masks.check(dev)
            entry = plotted["masks"][clock]
            assert entry["passed"] == result.passed
            assert entry["worst_margin_s"] == pytest.approx(result.worst_margin_s, rel=1e-12)
            expected = [None if not np.isfinite(v) else v for v in masks.limit_s(metric, dev.tau_s)]
            assert entry["limit"] == pytest.approx(expected, rel=1e-12)


def test_pooled_oadev_of_one_trial_is_plain_oadev_and_pooling_adds_degrees_of_freedom():
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.standard_normal((3, 4000)), axis=1) * 1e-9
    one = pooled_oadev(x[:1], 1.0)
    octave = st.tau_grid("octave", x.shape[1], 1.0, "oadev")
    plain = st.oadev(x[0], 1.0, octave)
    np.testing.assert_allclose(one.dev, plain.dev, rtol=1e-14)
    np.testing.assert_allclose(one.lo, plain.lo, rtol=1e-12)
    pooled = pooled_oadev(x, 1.0)
    per_trial = np.array([st.oadev(row, 1.0, octave).dev ** 2 for row in x])
    np.testing.assert_allclose(pooled.dev, np.sqrt(per_trial.mean(axis=0)), rtol=1e-14)
    np.testing.assert_allclose(pooled.edf, 3 * st.oadev(x[0], 1.0, octave).edf, rtol=1e-14)
    with pytest.raises(ValueError, match="x_s has shape"):
        pooled_oadev(x[0], 1.0)


def test_pooled_oadev_leaves_out_a_trial_only_where_its_gaps_leave_it_no_term():
    rng = np.random.default_rng(6)
    x = np.cumsum(rng.standard_normal((3, 4000)), axis=1) * 1e-9
    x[2, 100:3900] = np.nan  # trial 2 keeps terms at short taus only
    taus = np.array([1.0, 2.0, 1000.0])
    pooled = pooled_oadev(x, 1.0, taus)
    per_trial = np.array([st.oadev(row, 1.0, taus).dev for row in x])
    assert np.isfinite(per_trial[2, 0]) and np.isnan(per_trial[2, 2])
    np.testing.assert_allclose(pooled.dev[0], np.sqrt(np.mean(per_trial[:, 0] ** 2)), rtol=1e-14)
    np.testing.assert_allclose(pooled.dev[2], np.sqrt(np.mean(per_trial[:2, 2] ** 2)), rtol=1e-14)
    assert pooled.edf[2] == 2 * pooled_oadev(x[:1], 1.0, taus).edf[2]


def test_missing_data_folder_is_named_in_the_error(tmp_path):
    with pytest.raises(InputError, match="data_dir"):
        validation.write_validation_figures(tmp_path / "out", tmp_path / "nowhere")


def test_validate_without_the_data_folder_is_a_one_line_error(tmp_path):
    result = CliRunner().invoke(app, ["validate", "--data", str(tmp_path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "no stability/ folder" in result.stderr
