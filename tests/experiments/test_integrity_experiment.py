"""`chronofuse reproduce integrity`: the experiment's numbers, files and command."""

import json

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.analysis.metrics import clopper_pearson
from chronofuse.cli import reproduce as reproduce_cli
from chronofuse.experiments.integrity import (
    STAGE_S_PER_UNIT,
    IntegrityConfig,
    independent_epochs,
    run_integrity,
)

SMALL = IntegrityConfig(pfa_trials=60, pfa_steps=3_000, training_lengths=(200, 5_000), training_repeats=4,
                        training_test_trials=10, training_test_steps=3_000, detection_trials=40)


HEARD = []


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("integrity")
    return out, run_integrity(out, config=SMALL, progress=lambda message, fraction=None: HEARD.append((message, fraction)))


def test_the_run_says_each_stage_with_the_fraction_of_the_whole_done(small_run):
    fractions = [f for _, f in HEARD]
    assert None not in fractions and fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] < 1.0
    messages = [m for m, _ in HEARD]
    assert messages[:4] == [f"false alarms at P_fa {p:g}" for p in (1e-1, 1e-2, 1e-3, 1e-4)]
    assert messages[-1] == "figures" and "training on 5000 epochs" in messages and "detection of drag" in messages
    # the stages' shares are their detector-epochs at the measured rates: false alarms 4 P_fa x 4 detectors x
    # 60 x 3000, training 2 lengths x 2 fits x 4 x 10 x 3000, detection 4 kinds x 11 sizes x 4 x 40 x 260
    rate = STAGE_S_PER_UNIT
    s = [2.88e6 * rate[0], 4.8e5 * rate[1], 1.8304e6 * rate[2], rate[3]]
    at = dict(HEARD)
    assert at["false alarms at P_fa 0.001"] == pytest.approx(s[0] / 2 / sum(s))
    assert at["training on 200 epochs"] == pytest.approx(s[0] / sum(s))
    assert at["detection of step"] == pytest.approx((s[0] + s[1]) / sum(s))
    assert at["figures"] == pytest.approx(1.0 - s[3] / sum(s))


def test_report_folder_holds_figures_tables_summary_and_markdown(small_run):
    out, summary = small_run
    for name in summary["files"]:
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "summary.json").read_text())["window"] == 20
    assert "False-alarm rate" in (out / "README.md").read_text()


def test_hod_false_alarm_rates_track_nominal_over_four_decades(small_run):
    _, summary = small_run
    hod = [r for r in summary["false_alarms"] if r["detector"] == "hod-chi2"]
    assert [r["pfa"] for r in hod] == [1e-1, 1e-2, 1e-3, 1e-4]
    for r in hod[:2]:  # enough independent epochs for a tight check at 1e-1 and 1e-2
        assert r["nominal_in_ci99"], r
    assert all(r["rate_all_epochs"] < 3 * r["pfa"] + 1e-3 for r in hod)


def test_hod_detects_a_drag_off_far_smaller_than_the_single_epoch_threshold_can(small_run):
    _, summary = small_run
    best = summary["min_size_p90"]["drag"]
    assert best["hod-chi2"] is not None and best["single-epoch"] is not None
    assert best["hod-chi2"] * 5 <= best["single-epoch"]
    rows = [r for r in summary["detection"] if r["kind"] == "drag" and r["detector"] == "hod-chi2"
            and r["size_sigma"] == best["hod-chi2"]]
    assert np.isfinite(rows[0]["median_delay_s"]) and rows[0]["median_delay_s"] <= SMALL.horizon


def test_training_rows_compare_both_noise_fits(small_run):
    _, summary = small_run
    assert {(r["method"], r["training_epochs"]) for r in summary["training"]} == {
        (m, n) for m in ("whittle", "autocorrelation") for n in (200, 5_000)}


def test_clopper_pearson_interval_covers_and_matches_the_beta_quantiles():
    lo, hi = clopper_pearson(10, 1000)
    assert lo < 0.01 < hi
    assert clopper_pearson(0, 100)[0] == 0.0
    # independent test epochs are window + 2 apart
    assert np.all(np.diff(independent_epochs(200, 20, 30)) == 22)


def test_reproduce_integrity_quick_command_writes_the_report(tmp_path, monkeypatch):
    # the command's own quick settings take ~15 s (measured in the report); a smaller config keeps this fast
    monkeypatch.setattr(IntegrityConfig, "quick", classmethod(lambda cls: SMALL))
    app = typer.Typer()
    reproduce_cli.register(app)
    result = CliRunner().invoke(app, ["reproduce", "integrity", "--quick", "--out", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["quick"] is True and (tmp_path / "pfa.png").exists() and (tmp_path / "README.md").exists()
