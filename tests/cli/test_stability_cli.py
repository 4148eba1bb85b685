"""`chronofuse stability`: JSON shape, agreement with the library, and one-line errors with exit code 2."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.analysis import stability
from chronofuse.cli.main import app
from chronofuse.io.records import read_record

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_json_output_is_one_document_with_the_documented_shape(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    result = invoke("stability", path, "--rate", 1, "--dev", "adev,mdev,tdev", "--taus", "octave", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert (doc["n"], doc["rate"], doc["kind"]) == (1001, 1.0, "phase")
    assert set(doc["deviations"]) == {"adev", "mdev", "tdev"}
    for key in ("tau", "dev", "lo", "hi"):
        assert len(doc["deviations"]["adev"][key]) == len(doc["deviations"]["adev"]["tau"])


def test_cli_numbers_equal_the_library_numbers(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    doc = json.loads(invoke("stability", path, "--rate", 1, "--dev", "oadev", "--taus", "1,10,100", "--json").stdout)
    lib = stability.oadev(read_record(path, rate_hz=1.0).values, 1.0, np.array([1.0, 10.0, 100.0]))
    np.testing.assert_allclose(doc["deviations"]["oadev"]["dev"], lib.dev, rtol=1e-12)
    np.testing.assert_allclose(doc["deviations"]["oadev"]["tau"], [1, 10, 100])


def test_frequency_records_with_a_mask_and_a_plot(data_dir, tmp_path):
    path = data_dir / "stability/ocxo/ocxo_frequency.txt"
    png = tmp_path / "ocxo.png"
    result = invoke("stability", path, "--kind", "freq", "--rate", 1, "--nominal-hz", 10e6, "--dev", "adev,mtie",
                    "--mask", "prtc-a", "--plot", png, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["mask"] is not None and isinstance(doc["mask"]["passed"], bool)
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("text", "args", "expected"),
    [
        ("", ("--rate", 1), "bad.txt: no data lines"),
        ("abc\ndef\n", ("--rate", 1), "bad.txt:1: no data lines (only comments and text lines; the first, 'abc', holds no number)"),
        ("1e-9\n2e-9\nabc\n", ("--rate", 1), "bad.txt:3: cannot read 'abc' as a number"),
        ("t,y_ppb\n0,1\n1,2\n2,3\n", ("--kind", "phase"), "bad.txt:1: column 'y_ppb' is in ppb"),
        ("t,f_Hz\n0,1\n1,2\n2,3\n", (), "bad.txt:1: column 'f_Hz' is in Hz: give the nominal frequency"),
        ("01/02/2020 10:00:00,1e-9\n01/02/2020 10:00:01,2e-9\n", (), "bad.txt:1: '01/02/2020 10:00:00': day and month"),
        ("0 1e-9\n1 nan\n2 nan\n3 nan\n4 nan\n5 nan\n6 1e-9\n", ("--rate", 1), "bad.txt:2: 5 of 7 samples are missing"),
        ("0 1e-9\n2 2e-9\n1 3e-9\n", ("--rate", 0.5), "bad.txt:3: time is not increasing"),
        ("0 1e-9\n1 2e-9\n2.5 3e-9\n", (), "bad.txt:3: time step 1.5 s is not a whole number of 1 s"),
        ("1e-9\n2e-9\n3e-9\n", ("--rate", 1, "--dev", "hdev"), "bad.txt: hdev: the record has 3 samples, too few for hdev"),
        ("1,475\n1,482\n1,470\n", ("--rate", 1), "bad.txt:2: '1,482' after '1,475'"),
    ],
)
def test_bad_input_is_a_one_line_error_naming_file_and_line_with_exit_code_2(tmp_path, text, args, expected):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    result = invoke("stability", path, *args, "--json")
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and expected in lines[0], result.stderr


def test_an_unknown_statistic_or_mask_is_refused_with_exit_code_2(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    assert invoke("stability", path, "--rate", 1, "--dev", "adevv").exit_code == 2
    assert invoke("stability", path, "--rate", 1, "--mask", "prtc-z").exit_code == 2


def test_taus_beyond_the_record_are_dropped_with_a_one_line_warning_in_the_json(tmp_path):
    path = tmp_path / "short.txt"
    path.write_text("\n".join(f"{k}e-9" for k in range(12)) + "\n")
    result = invoke("stability", path, "--rate", 1, "--dev", "adev", "--taus", "1,1000", "--json")
    assert result.exit_code == 0 and result.stderr == ""
    doc = json.loads(result.stdout)
    assert doc["deviations"]["adev"]["tau"] == [1.0]
    assert len(doc["warnings"]) == 1 and "tau_s [1000.0] s dropped" in doc["warnings"][0]


def test_nist_1000_point_fractional_frequency_gives_the_published_adev_with_a_magnitude_warning(tmp_path):
    """NIST SP 1065 section 12.1 (p. 107) 1000-point set, values in [0, 1] read as fractional frequency;
    ADEV at 1, 10, 100 s from SP 1065 Table 31 (also allantools' tests/nbs14): 2.922319e-01, 9.965736e-02,
    3.897804e-02. MTIE at 1 s of integrated frequency is max |y| tau0 (a window of two phase points)."""
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    y = np.array(n) / 2147483647.0
    path = tmp_path / "nist1000.txt"
    path.write_text("".join(f"{v!r}\n" for v in y.tolist()))
    result = invoke("stability", path, "--kind", "freq", "--rate", 1, "--dev", "adev,mtie", "--taus", "1,10,100",
                    "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    np.testing.assert_allclose(doc["deviations"]["adev"]["dev"], [2.922319e-01, 9.965736e-02, 3.897804e-02],
                               rtol=1e-6)
    assert doc["deviations"]["mtie"]["dev"][0] == pytest.approx(np.max(np.abs(y)), rel=1e-12)
    assert any("implausible for a clock" in w for w in doc["warnings"])


def test_a_time_tagged_record_reports_its_jitter_and_gaps(tmp_path):
    rng = np.random.default_rng(2)
    t = 1.7e9 + np.arange(400) + rng.uniform(-1e-3, 1e-3, 400)
    keep = np.ones(400, bool)
    keep[50] = False
    path = tmp_path / "tagged.csv"
    path.write_text("time,x_ns\n" + "".join(f"{tk:.6f},{k}\n" for k, tk in zip(np.flatnonzero(keep), t[keep])))
    result = invoke("stability", path, "--dev", "adev", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert (doc["n"], doc["rate"], doc["gaps"]) == (400, 1.0, 1)
    assert 3e-4 < doc["jitter_rms_s"] < 8e-4 and doc["jitter_max_s"] < 1.01e-3


def test_the_nbs14_10_point_frequency_set_gives_its_published_adev_and_oadev(tmp_path):
    """NBS-14 10-point set (W. J. Riley, "The calculation of time domain frequency stability", and NIST
    SP 1065 p. 107; allantools' tests/nbs14): frequency 892, 809, 823, 798, 671, 644, 883, 903, 677;
    ADEV 91.22945 and 115.8082, OADEV 91.22945 and 85.95287 at tau = 1 and 2. Values far outside a clock's
    range: analysed as given, with a warning, not refused as absolute frequency."""
    path = tmp_path / "nbs14.txt"
    path.write_text("892\n809\n823\n798\n671\n644\n883\n903\n677\n")
    result = invoke("stability", path, "--kind", "freq", "--rate", 1, "--dev", "adev,oadev", "--taus", "1,2",
                    "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    np.testing.assert_allclose(doc["deviations"]["adev"]["dev"], [91.22945, 115.8082], rtol=1e-6)
    np.testing.assert_allclose(doc["deviations"]["oadev"]["dev"], [91.22945, 85.95287], rtol=1e-6)
    assert any("implausible for a clock" in w for w in doc["warnings"])


def test_the_names_the_command_lists_are_the_engines_statistics_and_masks():
    # cli/stability.py names them itself so that its options do not import the engine at start-up.
    from chronofuse.analysis.masks import MASKS
    from chronofuse.cli.stability import MASK_NAMES, STATISTIC_NAMES

    assert STATISTIC_NAMES == tuple(stability.STATISTICS)
    assert MASK_NAMES == tuple(MASKS)


def test_a_run_on_a_file_that_cannot_be_read_still_fails_cleanly_while_the_engine_loads(tmp_path):
    # The engine is imported and warmed on a thread while the file is read; a bad file ends the command
    # with the usual one-line error, whatever that thread is doing.
    bad = tmp_path / "bad.txt"
    bad.write_text("1.0\nabc\n2.0\n")
    result = runner.invoke(app, ["stability", str(bad), "--rate", "1", "--dev", "oadev,mtie", "--json"])
    assert result.exit_code == 2 and result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and "bad.txt:2: cannot read 'abc' as a number" in lines[0], result.stderr


def test_several_statistics_run_side_by_side_give_what_each_gives_alone(tmp_path):
    """The command runs several statistics on threads (the kernels release the GIL): each result must be
    the one the statistic gives when it is asked for alone."""
    rng = np.random.default_rng(5)
    path = tmp_path / "x.txt"
    np.savetxt(path, np.cumsum(rng.normal(size=20_000)) * 1e-9)
    names = ["oadev", "mtie", "mdev", "theo1", "tie_rms", "mtotdev"]  # two with numba-parallel kernels
    together = json.loads(CliRunner().invoke(app, ["stability", str(path), "--rate", "1", "--dev", ",".join(names),
                                                   "--json"]).stdout)
    for name in names:
        alone = json.loads(CliRunner().invoke(app, ["stability", str(path), "--rate", "1", "--dev", name,
                                                    "--json"]).stdout)
        assert together["deviations"][name] == alone["deviations"][name], name


def test_the_console_script_loses_nothing_on_its_fast_way_out(data_dir, tmp_path):
    """``main()`` freezes the heap before the interpreter exits (the exit's collections then skip what the
    run built): the JSON on stdout, the plot file and the exit codes must be what the in-process run gives."""
    import subprocess
    import sys

    path = data_dir / "stability/phasedat/PHASE.DAT"
    png = tmp_path / "phase.png"
    args = ["stability", str(path), "--rate", "1", "--dev", "oadev,mtie", "--taus", "octave", "--json"]
    child = subprocess.run([sys.executable, "-m", "chronofuse.cli.main", *args, "--plot", str(png)],
                           capture_output=True, text=True, timeout=120)
    assert child.returncode == 0, child.stderr
    doc, same = json.loads(child.stdout), json.loads(invoke(*args).stdout)
    assert doc["deviations"] == same["deviations"]
    assert png.read_bytes()[-12:] == b"\x00\x00\x00\x00IEND\xaeB`\x82"  # the PNG's closing chunk: written in full
    bad = subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "stability", str(tmp_path / "none.txt"),
                          "--rate", "1"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "none.txt" in bad.stderr


def test_an_in_process_run_leaves_garbage_collection_on_and_freezes_nothing(data_dir):
    """Collection is paused while the engine loads; outside the console script (whose process ends with
    the command) nothing may stay paused or frozen, or a long-lived caller such as this test session
    would never collect again."""
    import gc

    frozen = gc.get_freeze_count()
    result = invoke("stability", data_dir / "stability/phasedat/PHASE.DAT", "--rate", 1, "--dev", "oadev", "--json")
    assert result.exit_code == 0, result.output
    assert gc.isenabled() and gc.get_freeze_count() == frozen


def test_the_headline_command_draws_every_statistic_with_its_mask_and_lists_every_failing_tau(data_dir, tmp_path):
    """``--dev oadev,mtie --mask prtc-a --plot`` drew OADEV only and listed 4 failing taus of 7; now both
    panels are drawn (the figure is two panels wide) and the verdict names every failing tau."""
    path = data_dir / "stability/gps/gps_1pps_phase_data.txt.gz"
    png = tmp_path / "gps.png"
    result = invoke("stability", path, "--rate", 1, "--dev", "oadev,mtie,tdev", "--mask", "prtc-a,prtc-b", "--plot", png,
                    "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert [m["clock"] for m in doc["masks"]] == ["prtc-a", "prtc-b"]
    failing = doc["masks"][1]["mtie"]["failing_tau"]
    assert len(failing) > 4 and f"tau {', '.join(f'{t:g}' for t in failing)} s" in doc["masks"][1]["summary"]
    from PIL import Image

    with Image.open(png) as image:
        width, height = image.size
    assert width > 1.6 * height  # two panels side by side


def test_te_offset_arbitrary_leaves_the_counters_constant_out_of_the_verdict(data_dir):
    path = data_dir / "stability/Cs5071A/5071A_phase.txt.gz"
    measured = json.loads(invoke("stability", path, "--rate", 1, "--dev", "mtie", "--mask", "prtc-a", "--json").stdout)
    free = json.loads(invoke("stability", path, "--rate", 1, "--dev", "mtie", "--mask", "prtc-a", "--te-offset",
                             "arbitrary", "--json").stdout)
    assert measured["mask"]["passed"] is False and "cTE +801.9 ns" in measured["mask"]["summary"]
    assert free["mask"]["passed"] is True and free["mask"]["time_error"] is None


def test_frequency_input_reports_its_gap_rule_and_mean_convention(tmp_path):
    path = tmp_path / "y.txt"
    rng = np.random.default_rng(4)
    y = rng.standard_normal(3000) * 1e-11 + 5e-10
    y[[10, 2000]] = np.nan
    path.write_text("".join(f"{v!r}\n" for v in y.tolist()))
    keep = json.loads(invoke("stability", path, "--kind", "freq", "--rate", 1, "--dev", "mtie,oadev", "--json").stdout)
    remove = json.loads(invoke("stability", path, "--kind", "freq", "--rate", 1, "--dev", "mtie,oadev", "--freq-mean",
                               "remove", "--json").stdout)
    assert keep["gap_rule"] == "span" and keep["deviations"]["oadev"]["gap_rule"] == "span"
    assert keep["frequency_mean"] == "keep" and remove["frequency_mean"] == "remove"
    assert keep["deviations"]["oadev"]["dev"] == pytest.approx(remove["deviations"]["oadev"]["dev"], rel=1e-9)
    assert keep["deviations"]["mtie"]["dev"][-1] > 10 * remove["deviations"]["mtie"]["dev"][-1]
