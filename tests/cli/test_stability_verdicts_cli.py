"""`chronofuse stability --mask`: the verdict words (PASS, FAIL, INCOMPLETE, NOT EVALUATED) on records whose
answer is known from a formula (a phase ramp's MTIE is its slope times tau), frequency input's offset and
gaps, and the plausibility of a nominal frequency."""

import json

import numpy as np
from typer.testing import CliRunner

from chronofuse.cli.main import app

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def _ramp(tmp_path, name, slope_ns_per_s, n, offset_ns=0.0):
    path = tmp_path / name
    t = np.arange(n)
    path.write_text("time_s,te_ns\n" + "".join(f"{k},{offset_ns + slope_ns_per_s * k:.6f}\n" for k in t))
    return path


def _doc(result):
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_mtie_over_the_limit_at_the_tables_upper_end_fails(tmp_path):
    # G.8271.1 Table 7-1: 580 ns up to 10,000 s inclusive; a 0.06 ns/s ramp: MTIE(10,000 s) = 600 ns
    path = _ramp(tmp_path, "ramp600.csv", 0.06, 20_500)
    doc = _doc(invoke("stability", path, "--dev", "mtie", "--taus", "8192,10000", "--mask", "g8271.1-c", "--json"))
    verdict = doc["masks"][0]
    # MTIE = 0.06 ns/s x tau passes 580 ns at tau > 9666.7 s: the refinement between 8192 s and 10,000 s
    # finds the first failing tau (within the low-pass's 0.1 ns) and the table's end fails
    failing = verdict["mtie"]["failing_tau"]
    assert verdict["verdict"] == "FAIL" and failing[-1] == 10_000.0 and 9666.0 <= failing[0] <= 9669.0
    text = invoke("stability", path, "--dev", "mtie", "--taus", "8192,10000", "--mask", "g8271.1-c").output
    assert "mask g8271.1-c: FAIL" in text and "10000 s" in text
    # t-bc-a, m <= tau <= 1000 s, 40 ns: a 0.04207 ns/s ramp over 2100 s is 42.07 ns at 1000 s
    path = _ramp(tmp_path, "ramp42.csv", 0.04207, 2100, offset_ns=0.0)
    verdict = _doc(invoke("stability", path, "--dev", "mtie", "--taus", "512,600,800,1000", "--mask", "t-bc-a",
                          "--json"))["masks"][0]
    assert 1000.0 in verdict["mtie"]["failing_tau"] and verdict["verdict"] == "FAIL"
    assert {600.0, 800.0, 1000.0} <= set(verdict["mtie"]["tau"])


def test_a_short_record_is_incomplete_in_text_and_json_and_never_pass(tmp_path):
    rng = np.random.default_rng(1)
    path = tmp_path / "short60.csv"
    path.write_text("time_s,te_ns\n" + "".join(f"{k},{5 + 0.1 * rng.standard_normal():.4f}\n" for k in range(60)))
    args = ("stability", path, "--dev", "mtie,tdev", "--mask", "t-bc-a,prtc-a,g8262-opt1")
    doc = _doc(invoke(*args, "--json"))
    assert [v["verdict"] for v in doc["masks"]] == ["INCOMPLETE"] * 3
    assert not any(v["passed"] for v in doc["masks"])
    assert all(v["mtie"]["not_covered_above"] == 30.0 for v in doc["masks"])
    text = invoke(*args).output
    assert "PASS" not in text and text.count("INCOMPLETE") == 3 and "not covered: tau > 30 s" in text
    assert "|cTE| (1000 s)" not in text  # not from 60 s of data


def test_nothing_evaluated_is_not_a_failure(tmp_path):
    path = _ramp(tmp_path, "off60.csv", 0.0, 4000, offset_ns=60.0)
    out = invoke("stability", path, "--dev", "mtie", "--mask", "t-bc-d", "--te-offset", "arbitrary").output
    assert "mask t-bc-d: NOT EVALUATED" in out and "FAIL" not in out


def _freq_with_gaps(tmp_path):
    rng = np.random.default_rng(2)
    y = 1e-11 * rng.standard_normal(10_000)
    y[rng.choice(y.size, 300, replace=False)] = np.nan  # 3 %
    path = tmp_path / "yg.txt"
    path.write_text("".join("nan\n" if np.isnan(v) else f"{v:.6e}\n" for v in y))
    return path


def test_frequency_input_leaves_the_absolute_limits_out_by_default(tmp_path):
    path = _freq_with_gaps(tmp_path)
    doc = _doc(invoke("stability", path, "--rate", 1, "--kind", "freq", "--dev", "mtie", "--mask", "prtc-a", "--json"))
    verdict = doc["masks"][0]
    assert doc["te_offset"] == "arbitrary" and verdict["offset"] == "arbitrary" and verdict["time_error"] is None
    assert any("no known constant offset" in n for n in doc["notes"])
    forced = _doc(invoke("stability", path, "--rate", 1, "--kind", "freq", "--dev", "mtie", "--mask", "prtc-a",
                         "--te-offset", "measured", "--json"))
    assert forced["masks"][0]["time_error"] is not None
    assert any("--te-offset measured on frequency input" in w for w in forced["warnings"])


def test_taus_left_blank_by_the_gap_rule_are_warned_with_the_reason(tmp_path):
    path = _freq_with_gaps(tmp_path)
    doc = _doc(invoke("stability", path, "--rate", 1, "--kind", "freq", "--dev", "oadev,tdev", "--taus",
                      "1,4,16,64,256", "--json"))
    blank = [t for t, n in zip(doc["deviations"]["oadev"]["tau"], doc["deviations"]["oadev"]["n"]) if n == 0]
    assert blank  # 3 % scattered gaps leave no 512-sample span whole
    assert any(w.startswith(f"oadev: {len(blank)} of 5 taus have no term") and "span rule" in w for w in doc["warnings"])
    samples = _doc(invoke("stability", path, "--rate", 1, "--kind", "freq", "--dev", "oadev", "--gap-rule", "samples",
                          "--json"))
    assert any("--gap-rule samples on frequency input" in w for w in samples["warnings"])


def test_a_wrong_nominal_frequency_is_warned_and_units_from_names_are_noted(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("t,Frequency (Hz)\n" + "".join(f"{k},{5e6 + 1e-5 * np.sin(k):.9f}\n" for k in range(200)))
    wrong = _doc(invoke("stability", path, "--nominal-hz", 1e7, "--dev", "oadev", "--json"))
    assert any("implausible for a clock" in w and "--nominal-hz" in w for w in wrong["warnings"])
    right = _doc(invoke("stability", path, "--nominal-hz", 5e6, "--dev", "oadev", "--json"))
    assert not any("implausible" in w for w in right["warnings"])
    assert "values in Hz, from the column name 'Frequency (Hz)'" in right["notes"]
