"""Every option of the ``chronofuse`` program, once: what it means, its unit, and the config fields it sets.

One name means one thing with one unit in every subcommand (a test walks the command tree and holds each
option to this table). The library names config fields in its errors (``{rate_hz} == -1, must be > 0``,
:class:`~chronofuse.validation.InputError`); :func:`label` writes a field as the option that sets it, so
the one message serves the library and the command line. Nothing here imports the library: ``--help``
stays fast.

Units: SI as in the library (``s``, ``Hz``, ``m``, ``m/s``, ...) unless the option's name carries its own
(``--jump-ns``, ``--max-tacc-ns``, ``--nominal-hz``); the unit is written in the option's help as
``(unit)``, or is the name's last word. ``None``: a count, a name, a path, a switch or a pure number.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Flag", "FLAGS", "FLAG_OF_FIELD", "label"]


@dataclass(frozen=True)
class Flag:
    """``meaning``: what the option sets; ``kind``: ``number``, ``count`` (an integer), ``text``, ``path`` or
    ``switch``; ``unit``: of a number; ``fields``: the library config fields it sets (their units may differ
    when the option's name carries its own, e.g. ``--jump-ns`` sets ``jump_s``)."""

    meaning: str
    kind: str
    unit: str | None = None
    fields: tuple[str, ...] = ()


_S, _HZ, _M = "s", "Hz", "m"

FLAGS: dict[str, Flag] = {
    # what every command shares
    "--json": Flag("print one JSON document on stdout", "switch"),
    "--quiet": Flag("print nothing but errors (and the JSON document with --json)", "switch"),
    "--out": Flag("where the command writes its files: a folder, or one file where the command says so", "path"),
    "--seed": Flag("root seed of the random streams (numpy SeedSequence; trial i draws from its own child)",
                   "count", fields=("seed",)),
    "--trials": Flag("Monte Carlo trials", "count", fields=("trials",)),
    "--quick": Flag("a shorter, smaller run (a smoke run)", "switch", fields=("quick",)),
    "--duration": Flag("length of the run, the drive or the record", "number", _S,
                       fields=("duration_s", "duration")),
    "--rate": Flag("sample rate of a record, or of the loop (the 1PPS: 1 Hz)", "number", _HZ, fields=("rate_hz",)),
    "--column": Flag("the value column of a text record (name, or 1-based number)", "text", fields=("column",)),
    "--station": Flag("one receiver or clock by name: a RINEX clock product's station, a receiver of a monitor log, "
                      "or a clock of a field log", "text", fields=("station", "receiver", "clock")),
    "--nav": Flag("a RINEX navigation file (broadcast ephemeris)", "path", fields=("nav",)),
    "--environment": Flag("the receivers' signal environment (open sky, urban canyon, ...)", "text",
                          fields=("scenario", "environment")),
    "--oscillator": Flag("oscillator preset", "text", fields=("oscillator", "preset")),
    "--receivers": Flag("number of receivers", "count", fields=("receivers", "n_receivers")),
    "--gdop-max": Flag("a receiver's 1PPS is usable only with GDOP below this", "number", fields=("gdop_max",)),
    # noise model (the clock's power-law coefficients, S_y(f) = h_a f^a) and the HOD detector
    "--h2": Flag("white PM level h2", "number", "s^3", fields=("h2",)),
    "--h1": Flag("flicker PM level h1", "number", "s^2", fields=("h1",)),
    "--h0": Flag("white FM level h0", "number", _S, fields=("h0",)),
    "--hm1": Flag("flicker FM level h-1 (dimensionless)", "number", fields=("hm1",)),
    "--hm2": Flag("random-walk FM level h-2", "number", "1/s", fields=("hm2",)),
    "--drift": Flag("linear frequency drift (aging)", "number", "1/s", fields=("drift_per_s",)),
    "--sigma-rho": Flag("mean pseudorange noise", "number", _M, fields=("sigma_rho_m",)),
    "--noise": Flag("a noise model JSON file (a previous detect --json document)", "path", fields=("noise",)),
    "--train": Flag("learn the missing noise parameters from the first stretch of this length", "number", _S,
                    fields=("train_s",)),
    "--detector": Flag("the clock-bias detector", "text", fields=("detector",)),
    "--test": Flag("a station's window test of each channel and of the receiver clock: chi-square or glr", "text",
                   fields=("test",)),
    "--codes": Flag("the pseudorange codes tested, comma-separated ('G C1C,E C1X')", "text", fields=("codes",)),
    "--window": Flag("HOD detector window", "count", "epochs", fields=("window",)),
    "--pfa": Flag("false-alarm probability per epoch", "number", fields=("pfa",)),
    "--raim": Flag("position-domain integrity of a RINEX observation file (protection levels, fault exclusion); "
                   "the position need not be known", "switch", fields=("raim",)),
    "--horizontal-alert-limit-m": Flag("horizontal alert limit of the protection level", "number", _M,
                                       fields=("horizontal_alert_limit_m",)),
    "--vertical-alert-limit-m": Flag("vertical alert limit of the protection level", "number", _M,
                                     fields=("vertical_alert_limit_m",)),
    "--integrity-risk": Flag("per-epoch budget of P(position error beyond its protection level and no alarm)",
                             "number", fields=("integrity_risk",)),
    "--p-md": Flag("missed-detection probability at which the minimum detectable bias is stated", "number",
                   fields=("p_md",)),
    "--position": Flag("static antenna position, ECEF X,Y,Z", "text", _M, fields=("position_m", "reference_m")),
    "--max-tacc-ns": Flag("UBX epochs whose time accuracy (tAcc) is over this are not tested", "number", "ns",
                          fields=("max_time_acc_s",)),
    "--json-lines": Flag("stream: one JSON line per epoch", "switch"),
    "--follow": Flag("the file is still being written: wait for new lines, stop after this long without any",
                     "number", _S, fields=("follow_s",)),
    # stability
    "--kind": Flag("phase (s) or fractional frequency record", "text", fields=("kind",)),
    "--dev": Flag("the statistics to compute", "text", fields=("dev",)),
    "--taus": Flag("averaging times: octave, decade, all or a list", "text", _S, fields=("taus", "tau_s")),
    "--mask": Flag("ITU-T mask to check", "text", fields=("mask",)),
    "--plot": Flag("write a PNG plot", "path", fields=("plot",)),
    "--export-stable32": Flag("also write the record read as a Stable32 data file (gaps as 0)", "path",
                              fields=("export_stable32",)),
    "--nominal-hz": Flag("nominal frequency of an absolute frequency record", "number", _HZ,
                         fields=("nominal_hz",)),
    "--ci": Flag("confidence level of the intervals (0.683: one sigma)", "number", fields=("ci",)),
    "--no-bias-correction": Flag("total deviations without bias correction", "switch",
                                 fields=("bias_correction",)),
    "--zero-is-gap": Flag("a value of 0 is a missing sample (Stable32's convention)", "switch",
                          fields=("zero_is_gap",)),
    "--gap-rule": Flag("when a term is skipped for gaps: samples (its own missing) or span (any it spans)", "text",
                       fields=("gap_rule",)),
    "--te-offset": Flag("the record's constant offset is time error (measured) or not (arbitrary)", "text",
                        fields=("te_offset",)),
    "--freq-mean": Flag("frequency input: keep or remove the mean frequency before integrating to phase", "text",
                        fields=("freq_mean",)),
    # receivers: inspect and monitor
    "--db": Flag("the SQLite (WAL) log of every epoch", "path", fields=("db",)),
    "--replay": Flag("replay a recording as a receiver", "path", fields=("replay",)),
    "--replay-speed": Flag("replay pace, a factor of real time", "number", fields=("replay_speed",)),
    "--report": Flag("summarize this log DB instead of monitoring", "path", fields=("report",)),
    "--jump-ns": Flag("offset jump between receivers flagged above this", "number", "ns", fields=("jump_s",)),
    "--json-lines-file": Flag("append each committed epoch as a JSON line to this file", "path",
                              fields=("json_lines_file",)),
    "--stale-s": Flag("a receiver silent for longer than this is stale", "number", _S, fields=("stale_s",)),
    "--connect-timeout-s": Flag("how long a source that cannot be opened at the start is retried", "number", _S,
                                fields=("connect_timeout_s",)),
    "--reconnect-timeout-s": Flag("how long a source that went down is retried", "number", _S,
                                  fields=("reconnect_timeout_s",)),
    "--http": Flag("serve the dashboard, status and metrics at HOST:PORT", "text", fields=("http",)),
    "--on-alarm": Flag("a shell command run once per alarm event", "text", fields=("on_alarm",)),
    "--webhook": Flag("a URL each alarm event is posted to", "text", fields=("webhook",)),
    "--chrony-sock": Flag("chronyd's refclock SOCK path fed integrity-gated samples", "path", fields=("chrony_sock",)),
    "--no-table": Flag("no live table, even on a terminal", "switch"),
    # the monitor's log
    "--from": Flag("start of the time span, ISO 8601 UTC (inclusive)", "text", fields=("start_gps_ns",)),
    "--to": Flag("end of the time span, ISO 8601 UTC (exclusive)", "text", fields=("end_gps_ns",)),
    "--bin": Flag("length of each time bin of a table", "number", _S, fields=("bin_s",)),
    # the disciplined oscillator
    "--controller": Flag("the loop controller (servo)", "text", fields=("controller",)),
    "--dac-bits": Flag("DAC resolution", "count", "bits", fields=("dac_bits",)),
    "--loop-bandwidth": Flag("PI loop natural frequency", "number", _HZ, fields=("loop_bandwidth_hz",)),
    "--fusion": Flag("fusion (inverse-variance) or selection (best source)", "text", fields=("fusion",)),
    "--design": Flag("how the Kalman controllers are designed: fit (learnt from a calibration record) or datasheet",
                     "text", fields=("design",)),
    "--integrity-pfa": Flag("exclude receivers on clock-bias HOD alarms at this false-alarm probability",
                            "number", fields=("integrity_pfa",)),
    "--reference": Flag("a real 1PPS phase record against a reference clock", "path", fields=("reference",)),
    "--oscillator-file": Flag("an oscillator JSON file (chronofuse characterize --out writes one)", "path",
                              fields=("oscillator_file",)),
    "--temperature-column": Flag("the column of the oscillator's temperature (degC, or K when its name ends in _k)",
                                 "text", fields=("temperature_column",)),
    "--receiver-sigma": Flag("white phase noise of the receiver a loop is designed for", "number", _S,
                             fields=("receiver_sigma_s",)),
    # positioning
    "--systems": Flag("GNSS constellations used", "text", fields=("systems",)),
    "--ins": Flag("IMU grade", "text", fields=("ins",)),
    "--smooth": Flag("add the RTS-smoothed solution", "switch", fields=("smooth",)),
    "--imu-rate": Flag("IMU sample rate", "number", _HZ, fields=("imu_rate_hz",)),
    "--speed": Flag("vehicle speed", "number", "m/s", fields=("speed_m_per_s",)),
    "--obs": Flag("a RINEX observation file", "path", fields=("obs",)),
    "--imu": Flag("an IMU log aligned with the observations by GPS time", "path", fields=("imu",)),
    "--coupling": Flag("how the GNSS measurements enter the GNSS/INS filter: loose or tight", "text",
                       fields=("coupling",)),
    "--start": Flag("first epoch, after the file's first", "number", _S, fields=("start_s",)),
    "--end": Flag("last epoch, after the file's first", "number", _S, fields=("end_s",)),
    "--elevation-mask-deg": Flag("elevation mask", "number", "deg", fields=("elevation_mask_deg",)),
    "--ionosphere": Flag("ionospheric delay model: klobuchar or none", "text", fields=("ionosphere",)),
    "--troposphere": Flag("tropospheric delay model: saastamoinen or none", "text", fields=("troposphere",)),
    # two-way links and swarms
    "--algorithm": Flag("sync algorithms, comma-separated, or all", "text", fields=("algorithm", "algorithms")),
    "--urt-mode": Flag("URT compensation: paper (the source paper's) or calibrated", "text", fields=("urt_mode",)),
    "--velocity": Flag("radial velocity between the nodes (opening > 0)", "number", "m/s",
                       fields=("velocity_m_s", "velocity")),
    "--distance": Flag("initial distance between the nodes", "number", _M, fields=("distance_m", "distance")),
    "--acceleration": Flag("radial acceleration", "number", "m/s^2", fields=("acceleration_m_s2",)),
    "--reply-delay": Flag("reply slot T_B", "number", _S, fields=("reply_delay_s",)),
    "--urt": Flag("fixed unequal reply time", "number", _S, fields=("urt_fixed_s",)),
    "--urt-jitter": Flag("URT jitter sigma", "number", _S, fields=("urt_jitter_s",)),
    "--snr": Flag("link signal-to-noise ratio", "number", "dB", fields=("snr_db",)),
    "--toa-model": Flag("TOA noise model: table (the source paper's) or crb (Cramér-Rao form)", "text",
                        fields=("toa_model",)),
    "--exchanges": Flag("two-way exchanges per run", "count", fields=("exchanges", "steps")),
    "--offset-mean": Flag("prior mean of the clock offset B - A at the start", "number", _S, fields=("offset_mean_s",)),
    "--offset-sigma": Flag("prior sigma of the clock offset, drawn per trial", "number", _S, fields=("offset_sigma_s",)),
    "--skew-mean": Flag("prior mean of the fractional frequency offset B - A", "number", fields=("skew_mean",)),
    "--skew-sigma": Flag("prior sigma of the frequency offset, drawn per trial", "number", fields=("skew_sigma",)),
    "--urt-sigma": Flag("spread of the fixed URT across links, drawn per trial", "number", _S, fields=("urt_sigma_s",)),
    "--range-spread": Flag("half-width of the initial range drawn per trial", "number", _M, fields=("range_spread_m",)),
    "--calibration-duration": Flag("the URT calibration window (one GNSS time comparison a second)", "number", _S,
                                   fields=("calibration_duration_s",)),
    "--reference-sigma": Flag("each node's GNSS time error during the URT calibration", "number", _S,
                              fields=("calibration_reference_sigma_s", "reference_sigma_s")),
    "--common-velocity": Flag("both nodes' velocity along the line of sight", "number", "m/s",
                              fields=("common_velocity_m_s",)),
    "--cross-velocity": Flag("B's velocity across the line of sight", "number", "m/s", fields=("cross_velocity_m_s",)),
    "--latitude": Flag("put the nodes on the rotating Earth at this latitude", "number", "deg", fields=("latitude_deg",)),
    "--bearing": Flag("bearing of the line of sight from north", "number", "deg", fields=("bearing_deg",)),
    "--manoeuvre": Flag("B's manoeuvre (none, turn, climb)", "text", fields=("manoeuvre",)),
    "--load-factor": Flag("the manoeuvre's load factor", "number", "g", fields=("load_factor_g",)),
    "--reply-jitter": Flag("sigma of B's reply slot, reported in T_B", "number", _S, fields=("reply_jitter_s",)),
    "--nlos": Flag("probability that an arrival is a reflected (NLOS) path", "number", fields=("nlos_probability",)),
    "--loss": Flag("fraction of exchanges lost, in Gilbert-Elliott bursts", "number", fields=("loss_fraction",)),
    "--loss-burst": Flag("mean length of a loss burst", "number", "exchanges", fields=("loss_burst_mean",)),
    "--clock-truth": Flag("clock truth: power-law (the preset) or markov (the filters' own model)", "text",
                          fields=("clock_truth",)),
    "--interval": Flag("exchange interval", "number", _S, fields=("interval_s",)),
    "--threshold": Flag("convergence threshold of K*", "number", _S, fields=("threshold_s",)),
    "--model": Flag("trained BP network file", "path", fields=("model", "bp")),
    "--lstm-model": Flag("trained LSTM network file", "path", fields=("lstm_model", "lstm")),
    "--outage": Flag("exchanges K0:K1 lost (robustness)", "text", fields=("outage",)),
    "--true-offset": Flag("every trial's true initial offset instead of a prior draw", "number", _S,
                          fields=("true_offset_s",)),
    "--param": Flag("the link parameter swept", "text", fields=("param",)),
    "--values": Flag("the swept values, in the SI unit of --param", "text", fields=("values",)),
    "--chunk-trials": Flag("trials per task (fixes the random streams)", "count", fields=("chunk_trials",)),
    "--scheduler": Flag("where trials run: serial, local (a Dask LocalCluster) or tcp://HOST:PORT", "text",
                        fields=("scheduler",)),
    "--device": Flag("where networks train: cpu, cuda or auto", "text", fields=("device",)),
    "--nodes": Flag("aircraft in the swarm", "count", fields=("nodes",)),
    "--topology": Flag("swarm topology", "text", fields=("topology",)),
    "--area": Flag("side of the square the swarm's nodes start in", "number", _M, fields=("area_m",)),
    "--radio-range": Flag("largest range of a link", "number", _M, fields=("radio_range_m",)),
    "--neighbours": Flag("links to the nearest nodes, at most this many each", "count", fields=("neighbours",)),
    "--leader-loss-at": Flag("when the swarm's leader leaves (< 0: never)", "number", _S, fields=("leader_loss_at_s",)),
    "--cut-off": Flag("NODE:FROM:TO, all of a node's links down", "text", _S, fields=("cut_off",)),
    "--leader-oscillator": Flag("oscillator preset of the swarm's first leader", "text", fields=("leader_oscillator",)),
    "--mean-up": Flag("mean time a link stays up (inf: always)", "number", _S, fields=("mean_up_s",)),
    "--mean-down": Flag("mean time a link stays down", "number", _S, fields=("mean_down_s",)),
    # reproductions and validation
    "--figure": Flag("which figure of the source paper", "text", fields=("figure",)),
    "--data": Flag("the real data folder", "path", fields=("data", "data_dir")),
    "--replot": Flag("redraw a reproduction's figures and report from its stored results", "switch"),
}

#: Library config field -> the option that sets it (the table above, read the other way).
FLAG_OF_FIELD: dict[str, str] = {field: name for name, flag in FLAGS.items() for field in flag.fields}

# Fields whose option writes the value in another unit (the name's): an error names both.
_OTHER_UNIT = {"max_time_acc_s", "jump_s"}


def label(field: str) -> str:
    """How the command line writes a library config field in an error: its option (``rate_hz`` ->
    ``--rate``); the option and the field where their units differ (``max_time_acc_s (--max-tacc-ns)``);
    the field itself where no option sets it."""
    flag = FLAG_OF_FIELD.get(field)
    if flag is None:
        return field
    return f"{field} ({flag})" if field in _OTHER_UNIT else flag
