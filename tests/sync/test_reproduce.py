"""The swarm report: verdicts follow the rules they state, and a quick reproduction writes figures, tables and
a report whose every number is in its swarm.json; --replot redraws them from it."""

import json

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.experiments.swarm_reproduce import verdict


def _row(rmse, lo, hi, bound):
    return {"rmse_ns": rmse, "rmse_lo_ns": lo, "rmse_hi_ns": hi, "bound_rms_ns": bound}


def test_a_below_claim_is_reproduced_only_when_the_whole_interval_is_below_and_unreachable_under_the_bound():
    assert verdict("<", 0.3, _row(0.2, 0.18, 0.25, 0.15)) == "reproduced"
    assert verdict("<", 0.3, _row(0.29, 0.25, 0.33, 0.15)).startswith("not reproduced")
    assert verdict("<", 0.2, _row(0.35, 0.3, 0.4, 0.33)) == "not reachable: the bound is 0.33 ns"
    assert verdict("~", 1.8, _row(2.0, 1.9, 2.1, 0.3)) == "reproduced"
    assert verdict("~", 13.0, _row(22.0, 21.0, 23.0, 0.3)) == "not reproduced: ours is 1.7x the paper's"


@pytest.mark.slow
def test_a_quick_reproduction_writes_its_figures_and_a_report_that_replots_from_its_json(tmp_path):
    runner = CliRunner()
    result = runner.invoke(app, ["reproduce", "swarm", "--quick", "--figure", "9", "--out", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert (tmp_path / "fig9.png").stat().st_size > 0 and (tmp_path / "fig9_summary.csv").exists()
    text = (tmp_path / "README.md").read_text()
    assert "| 9 | rtt-rvc-kf-bp |" in text and "no model file given" in text
    assert "A changed reply delay after calibration" in text and "the leader lost" in text
    assert {r["change"] for r in doc["urt_changes"]} == {"step +5 ns", "step -5 ns", "ramp 1 ns/min"}
    (tmp_path / "fig9.png").unlink()
    again = runner.invoke(app, ["reproduce", "swarm", "--replot", "--out", str(tmp_path)])
    assert again.exit_code == 0, again.output
    assert (tmp_path / "fig9.png").exists() and (tmp_path / "README.md").read_text() == text


def test_a_claim_without_an_interval_gets_no_interval_based_verdict():
    nan = float("nan")
    assert verdict("<", 0.2, _row(0.1, nan, nan, 0.05)).startswith("no verdict: 0.1 ns without an interval")
    assert verdict("<", 0.2, _row(0.1, None, None, 0.3)) == "not reachable: the bound is 0.3 ns"
    assert verdict("~", 1.8, _row(2.0, None, None, 0.3)) == "reproduced"  # within 25 %, no interval needed
    assert verdict("~", 13.0, _row(22.0, nan, nan, 0.3)) == "not reproduced: ours is 1.7x the paper's"


def test_the_progress_of_a_reproduction_shares_its_stages_by_their_measured_costs():
    from chronofuse.experiments.swarm_reproduce import stage_weights

    algs = ("ptp-mls", "rtt-rvc", "rtt-rvc-kf", "doppler-kf")
    quick = stage_weights({"9": algs}, 8, 1000, 8, 12)
    assert quick == pytest.approx([224.0, 136.0, 56.0])  # the quick run these rates were measured on
    assert stage_weights({"9": algs}, 8, 1000, 0, 12) == pytest.approx([224.0])  # no checks: no such stages
    full = stage_weights({"6": algs, "9": algs + ("rtt-rvc-kf-bp",)}, 100, 2000, 30, 50)
    assert full[0] == pytest.approx(6 * 4 * 100 * 2000 * 224.0 / 224000) and full[1] / full[0] == pytest.approx(7 * 5 / 24)


def test_a_quick_figure_says_the_fraction_of_its_links_done(tmp_path, monkeypatch):
    import chronofuse.experiments.swarm_reproduce as rep

    heard = []
    param, _, base, _ = rep.FIGURES["9"]
    monkeypatch.setitem(rep.FIGURES, "9", (param, [0.0, 20e-9], base, ("doppler-kf",)))  # 16 link-runs, not 224
    rep.reproduce_swarm(tmp_path, figures=("9",), quick=True, checks=False,
                        progress=lambda message, fraction=None: heard.append((message, fraction)))
    assert {m for m, _ in heard} == {"figure 9"}
    fractions = [f for _, f in heard]
    assert fractions[0] == 0.0 and fractions[-1] == pytest.approx(1.0) and fractions == sorted(fractions)
    assert fractions == [0.0, 0.5, 1.0]  # one step per task (a point's 10 links) as it ends
