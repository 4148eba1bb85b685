"""Each command's HTML report, opened in headless Chromium (Debian's, under chromedriver): every figure loads
(``naturalWidth > 0``), every verdict is on the page with its reason, and the reasons say what the JSON
beside the page says (which limit failed, at which tau, by how much).

The runs are short: a one-hour scenario (the shortest the disciplining stage takes), a one-hour GNSSDO, two
swarm links, a real 241,218 s 1PPS record, a simulated clock bias with and without an injected step, and a
replayed u-blox recording for the monitor.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from selenium.webdriver.common.by import By
from typer.testing import CliRunner

from _helpers import receivers_dir
from _real_parts import chromium
from chronofuse.cli.main import app
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from conftest import real_data_dir

runner = CliRunner()

SCENARIO = """
name = "report-test"
description = "one hour, for the report test"
duration_s = 3600
[receivers]
count = 2
scenario = "urban-canyon"
[analysis]
mask = "prtc-a"
deviations = ["oadev", "mtie", "tdev"]
[discipline]
outage_s = 600
[swarm]
followers = 1
"""


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    driver = chromium(tmp_path_factory.mktemp("profile"))
    yield driver
    driver.quit()


def _page(browser, path: Path) -> dict:
    """Open ``path``; return its images' natural widths and its verdict rows (subject, word, reason)."""
    browser.get(path.resolve().as_uri())
    browser.execute_async_script("""
        const done = arguments[arguments.length - 1];
        Promise.all([...document.images].map(i => i.complete ? 0 : new Promise(r => { i.onload = i.onerror = r; })))
            .then(() => done());""")
    widths = browser.execute_script("return [...document.images].map(i => [i.dataset.file, i.naturalWidth]);")
    rows = [(tr.get_attribute("data-subject"), tr.get_attribute("data-verdict"),
             tr.find_element(By.CSS_SELECTOR, "td.reason").text)
            for tr in browser.find_elements(By.CSS_SELECTOR, "tr.verdict")]
    return {"images": widths, "verdicts": {subject: (word, reason) for subject, word, reason in rows}}


def _no_missing_image(page: dict, at_least: int) -> None:
    assert len(page["images"]) >= at_least, page["images"]
    assert all(width > 0 for _, width in page["images"]), page["images"]


def _every_verdict_has_a_reason(page: dict) -> None:
    assert page["verdicts"]
    for subject, (word, reason) in page["verdicts"].items():
        assert word in ("PASS", "FAIL", "NOT GIVEN") and len(reason) > 10, (subject, word, reason)


def _worst(part: dict) -> tuple[float, float]:
    """(tau, excess in ns) of a mask check's worst violation, from the JSON's arrays."""
    k = min((i for i, used in enumerate(part["evaluated"]) if used), key=lambda i: part["margin"][i])
    return part["tau"][k], -part["margin"][k] * 1e9


def _says_where_and_how_much(reason: str, verdict: dict) -> None:
    for metric in ("mtie", "tdev"):
        part = verdict[metric]
        if part is not None and part["status"] == "fail":
            tau, excess = _worst(part)
            assert f"{metric.upper()} over its limit" in reason
            assert f"worst at tau {tau:g} s" in reason and f"{excess:.1f} ns over" in reason, reason


def test_the_run_report_shows_every_figure_and_every_verdict_with_its_reason(browser, tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "run"
    result = runner.invoke(app, ["run", str(scenario), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    page = _page(browser, out / "report.html")
    pngs = sorted(out.rglob("*.png"))
    _no_missing_image(page, at_least=len(pngs))
    assert {f for f, _ in page["images"]} == {p.name for p in pngs}
    _every_verdict_has_a_reason(page)
    verdicts = page["verdicts"]
    for label, v in summary["mask"]["receivers"].items():
        word, reason = verdicts[f"{label} against prtc-a"]
        assert word == {"PASS": "PASS", "FAIL": "FAIL"}.get(v["verdict"], "NOT GIVEN")
        _says_where_and_how_much(reason, v)
    # raw urban-canyon receivers are no PRTC: the page must not pass them
    assert any(verdicts[f"{label} against prtc-a"][0] == "FAIL" for label in summary["mask"]["receivers"])
    for name in ("prtc-a", "prtc-b", "g811"):  # the disciplined output is checked against the masks
        v = summary["discipline"]["masks"][name]
        word, reason = verdicts[f"disciplined output against {name}"]
        assert word == {"PASS": "PASS", "FAIL": "FAIL"}.get(v["verdict"], "NOT GIVEN")
        _says_where_and_how_much(reason, v)
    d = summary["discipline"]
    word, reason = verdicts["time error within 1.1x of the clairvoyant bound"]
    assert word == ("PASS" if d["time_error_rms_ns"] <= 1.1 * d["optimal_rms_ns"] else "FAIL")
    assert f"{d['time_error_rms_ns']:.1f} ns rms" in reason
    assert "locked only while its criteria hold" in verdicts
    text = browser.find_element(By.TAG_NAME, "body").text
    assert "stop well before the run's 3600 s" in text and "terms there" in text  # short curves explained
    assert "follower" in text and "holdover" in text


def test_the_gnssdo_report(browser, tmp_path):
    out = tmp_path / "gnssdo"
    result = runner.invoke(app, ["gnssdo", "--environment", "outage", "--duration", "3600", "--trials", "1",
                                 "--seed", "1", "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    page = _page(browser, out / "report.html")
    _no_missing_image(page, at_least=3)
    _every_verdict_has_a_reason(page)
    for name, v in summary["masks"].items():
        assert page["verdicts"][f"disciplined output against {name}"][0] == {"PASS": "PASS", "FAIL": "FAIL"}.get(v["verdict"], "NOT GIVEN")


def test_the_stability_report_of_a_real_receiver_fails_prtc_a_and_says_why(browser, tmp_path):
    record = real_data_dir() / "stability" / "gps" / "gps_1pps_phase_data.txt.gz"
    plot = tmp_path / "gps.png"
    result = runner.invoke(app, ["stability", str(record), "--rate", "1", "--dev", "oadev,mtie", "--taus", "decade",
                                 "--mask", "prtc-a", "--plot", str(plot), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    doc = json.loads(result.stdout)
    page = _page(browser, plot.with_suffix(".html"))
    _no_missing_image(page, at_least=1)
    word, reason = page["verdicts"]["record against prtc-a"]
    assert word == "FAIL" and not doc["mask"]["passed"]
    _says_where_and_how_much(reason, doc["mask"])
    assert "max |TE| 320.9 ns against 100 ns" in reason


def test_the_swarm_report(browser, tmp_path):
    out = tmp_path / "swarm"
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "ptp-mls,rtt-rvc", "--trials", "10", "--seed", "1",
                                 "--exchanges", "500", "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    doc = json.loads(result.stdout)
    page = _page(browser, out / "report.html")
    _every_verdict_has_a_reason(page)
    for name in ("ptp-mls", "rtt-rvc"):
        word, reason = page["verdicts"][f"{name} does not beat the bound"]
        assert word == ("PASS" if doc["ratio_ci"][name][0] >= 0.9 else "FAIL")
        assert f"RMSE / bound {doc['ratio_to_bound'][name]:.3g}" in reason
    # too few trials for an interval: no verdict, not a FAIL (nor a zero-width PASS)
    few = tmp_path / "few"
    assert runner.invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc", "--trials", "2", "--exchanges", "200",
                               "--out", str(few), "--json"]).exit_code == 0
    word, reason = _page(browser, few / "report.html")["verdicts"]["rtt-rvc does not beat the bound"]
    assert word == "NOT GIVEN" and "too few for an interval" in reason


@pytest.mark.parametrize("step_ns", [0.0, 400.0])
def test_the_detect_report_says_alarm_or_not_and_why(browser, tmp_path, step_ns):
    x = simulate_clock_bias(ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0), interval_s=1.0, steps=900, trials=1,
                            seed=7).measured_s[0]
    if step_ns:
        x = inject(x, Anomaly("step", 600.0, offset_s=step_ns * 1e-9), 1.0)
    csv = tmp_path / "bias.csv"
    csv.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{v:.12e}\n" for k, v in enumerate(x)))
    report = tmp_path / "detect.html"
    result = runner.invoke(app, ["detect", str(csv), "--train", "300", "--report", str(report), "--json"])
    assert result.exit_code in (0, 1), result.output[-2000:]
    doc = json.loads(result.stdout)
    page = _page(browser, report)
    word, reason = page["verdicts"]["integrity"]
    if step_ns:
        assert result.exit_code == 1 and word == "FAIL" and f"{doc['n_alarms']} alarm(s)" in reason
        assert "the first at t = " in reason
    else:
        assert result.exit_code == 0 and word == "PASS" and "no alarm" in reason


def test_the_monitor_report_plots_each_receiver_on_a_time_axis_in_seconds(browser, tmp_path):
    f9p = receivers_dir() / "gpsd" / "ublox-zed-f9p_hpg1.11.log"  # 655 s of NAV-CLOCK clock bias
    db = tmp_path / "log.db"
    result = runner.invoke(app, ["monitor", "--replay", str(f9p), "--replay-speed", "1000", "--db", str(db), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    out = tmp_path / "report"
    result = runner.invoke(app, ["monitor", "--report", str(db), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    page = _page(browser, out / "report.html")
    _no_missing_image(page, at_least=2)  # the clock bias and its ADEV
    _every_verdict_has_a_reason(page)
    assert any(subject.endswith(": no alarm") for subject in page["verdicts"])


def test_the_time_axis_unit_follows_the_span():
    from chronofuse.report.figures import time_axis

    assert time_axis(152.0) == (1.0, "s")  # the monitor's 152 s replay: seconds, not 0.04 h
    assert time_axis(3600.0) == (60.0, "min")
    assert time_axis(86_400.0) == (3600.0, "h")
    assert math.isclose(time_axis(600.0)[0], 1.0) and np.isfinite(time_axis(1e7)[0])


def test_the_raim_report_gives_the_verdict_the_levels_and_every_faulty_epoch(browser, tmp_path):
    # The page of detect --raim had the clock-bias page's "integrity" row only, with no levels, no limits,
    # no satellite: a real IGS station clean (PASS everywhere), then the same station with a 150 m bias added
    # to one GPS satellite's every pseudorange for 100 epochs (FAIL, naming it).
    from _helpers import igs_station_catalogue
    from chronofuse.integrity.raim_station import raim_document
    from chronofuse.report.html import detect_page

    station = igs_station_catalogue()["ESBC"]
    position = ",".join(f"{v:.4f}" for v in station.reference_m)
    report = tmp_path / "raim.html"
    args = ["detect", str(station.obs_path), *sum((["--nav", str(p)] for p in station.nav_paths), []), "--raim",
            f"--position={position}", "--report", str(report), "--json", "--quiet"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output[-2000:]
    doc = json.loads(result.stdout)
    page = _page(browser, report)
    _every_verdict_has_a_reason(page)
    word, reason = page["verdicts"]["integrity (RAIM)"]
    assert word == "PASS" and f"{doc['n_tested']:,} tested epochs" in reason
    word, reason = page["verdicts"]["protection levels within the alert limits"]
    assert f"HPL median {doc['hpl_m']['median']:.1f} m" in reason and "HAL 40 m" in reason
    assert page["verdicts"]["the error stays inside the protection levels"][0] == "PASS"

    import dataclasses

    cached = station.observations().select(slice(0, 400))  # views of the cached file: copied before the fault
    obs = dataclasses.replace(cached, values={name: v.copy() for name, v in cached.values.items()})
    column = next(i for i, sat in enumerate(obs.satellites) if sat.startswith("G")
                  and np.isfinite(obs.values["C1C"][100:200, i]).all())
    for name, values in obs.values.items():
        if name.startswith("C"):
            values[100:200, column] += 150.0
    assert not np.shares_memory(obs.values["C1C"], cached.values["C1C"])
    faulty = raim_document(station.obs_path, station.nav_paths, observations=obs, navigation=station.navigation())
    assert faulty["state"] == "alarm"
    detect_page(faulty, tmp_path / "fault.html", str(station.obs_path))
    page = _page(browser, tmp_path / "fault.html")
    word, reason = page["verdicts"]["integrity (RAIM)"]
    assert word == "FAIL" and f"{len(faulty['alarms'])} epoch(s) detected a fault" in reason
    assert obs.satellites[column] in reason
    rows = browser.find_elements(By.CSS_SELECTOR, "table tbody tr")
    assert any(obs.satellites[column] in row.text for row in rows)
