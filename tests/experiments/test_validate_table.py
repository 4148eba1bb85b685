"""chronofuse validate prints one PASS/FAIL line per check from the records shipped inside the package, and
writes nothing unless asked; each check fails when its numbers are off."""

from __future__ import annotations

import copy
import json
import os

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.experiments.validation import run_validation, shipped_data
from chronofuse.experiments.validation_checks import checks


@pytest.fixture(scope="module")
def quick_numbers():
    return run_validation(quick=True)[0]


def test_the_records_ship_inside_the_package():
    data = shipped_data()
    assert data.parts[-2:] == ("chronofuse", "data")
    for name in ("gps/gps_1pps_phase_data.txt.gz", "gps/stable32_ADEV_decade.txt", "Cs5071A/5071A_phase.txt.gz",
                 "Cs5071A/mtie_decade.txt", "LICENSE-allantools.txt"):
        assert (data / "stability" / name).is_file(), name


def test_validate_prints_every_check_passing_and_writes_nothing(tmp_path):
    before = sorted(p.name for p in shipped_data().rglob("*"))
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        result = CliRunner().invoke(app, ["validate", "--quick", "--json"])
    finally:
        os.chdir(cwd)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["failed"] == 0 and doc["files"] == []
    assert len(doc["checks"]) == 15 and {c["verdict"] for c in doc["checks"]} == {"PASS"}
    assert list(tmp_path.iterdir()) == [] and sorted(p.name for p in shipped_data().rglob("*")) == before


def test_every_check_passes_on_the_quick_run(quick_numbers):
    verdicts = checks(quick_numbers)
    assert [c.name for c in verdicts if not c.passed] == []


@pytest.mark.parametrize("spoil, failing", [
    (lambda n: n["gps"]["ours"]["adev"].__setitem__("dev", np.asarray(n["gps"]["ours"]["adev"]["dev"]) * 1.001),
     "GPS 1PPS record: ADEV against Stable32"),
    (lambda n: n["gps"]["ours"]["tdev"].__setitem__("n", np.asarray(n["gps"]["ours"]["tdev"]["n"]) + 1),
     "GPS 1PPS record: TDEV terms per tau"),
    (lambda n: n["cs5071a"]["mtie"]["ours"].__setitem__("dev", np.asarray(n["cs5071a"]["mtie"]["ours"]["dev"]) * 0.999),
     "Cs 5071A record: MTIE against Stable32"),
    (lambda n: n["receiver"]["record"].__setitem__("analytic_worst_misfit", 0.06),
     "open-sky receiver model: analytic ADEV against the GPS record"),
    (lambda n: n["receiver"].__setitem__("ratio_sim_to_stable32", np.asarray(n["receiver"]["ratio_sim_to_stable32"]) * 1.2),
     "open-sky receiver model: simulated ADEV against the GPS record"),
    (lambda n: n["receiver"].__setitem__("ratio_raw_to_corrected", [1.0]),
     "open-sky receiver model: the raw 1PPS keeps the sawtooth"),
    (lambda n: n["oscillators"]["rb"].__setitem__("ratio_sim_to_theory",
                                                   np.asarray(n["oscillators"]["rb"]["ratio_sim_to_theory"]) * 1.06),
     "oscillator preset rb: simulated OADEV against theory"),
])
def test_a_check_fails_when_its_numbers_are_off_and_only_that_check(quick_numbers, spoil, failing):
    numbers = copy.deepcopy(quick_numbers)
    spoil(numbers)
    assert [c.name for c in checks(numbers) if not c.passed] == [failing]
