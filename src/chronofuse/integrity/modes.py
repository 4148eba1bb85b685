"""Clock-bias integrity on a data file: the mode chosen from what the file provides.

:func:`detect_file` is what ``chronofuse detect FILE`` does, as a library call that returns the same
document the command prints with ``--json``:

* a CSV (time and clock-bias columns) or a u-blox UBX capture (NAV-CLOCK ``clkB``) gives one receiver clock
  bias (:func:`chronofuse.io.clockbias.read_clock_bias`): **detection** mode, one
  :class:`~chronofuse.integrity.detector.HodDetector` over the record, after the receiver's millisecond
  clock resets are repaired and reported as clock events (:mod:`chronofuse.integrity.clock_events`);
* a RINEX 3 observation file (plain, gzip or Hatanaka) with its navigation files and the static antenna's
  ECEF position: **identification** mode on every code of every system, satellites named by exclusion, the
  receiver clock tested beside them (:mod:`chronofuse.integrity.station_mode`);
* a RINEX 2 observation file with a navigation file and the static antenna's ECEF position gives
  per-satellite clock biases: **identification** mode
  (:func:`chronofuse.integrity.identification.identify`: the common receiver clock removed, each channel's
  noise fitted on its own first ``train_s`` seconds; an alarm names its satellite).

Causal verdicts. Each epoch's verdict uses that epoch and earlier ones only: with ``train_s`` the first
``train_s`` seconds fit the noise model and are not tested (state ``training``); the test starts after them.

States (per epoch and overall, the ``state`` of the document). ``ok``: tested, no fault; ``alarm``: the
statistic is over its threshold (detection) or a channel is faulty (identification: raised when named,
cleared when consistent with the others again); ``unavailable``: integrity could not be tested: an epoch with no test (missing data, start-up
of the difference chain after a gap, training, the receiver reporting no valid fix (UBX NAV-SOL/PVT/STATUS)
or a time accuracy (UBX NAV-CLOCK tAcc) over ``max_time_acc_s``,
fewer than :data:`MIN_TESTED_CHANNELS` channels tested,
the position check failed). Overall the record is ``unavailable`` when training failed, the position is
off (the single-point fix of the data is farther than :data:`POSITION_TOLERANCE_M` from the position
given), or fewer than :data:`MIN_TESTED_FRACTION` of the epochs with data after training were tested; else
``alarm`` when any epoch alarmed, else ``ok``. The reasons are listed in ``unavailable_reasons``, the
untested stretches in ``unavailable`` (``from_ns``/``to_ns``/``reason``). :data:`EXIT_CODES` maps the
overall state to the command's exit status: 0 ok, 1 alarm, 3 unavailable (2 is bad input).

Times. Every epoch is an integer number of nanoseconds on the file's time axis (``t_ns``; the time column
for CSV, GPS time of week for UBX, since the first epoch for RINEX); ``t`` is the same in seconds, for
reading.

Noise parameters: ``h0``, ``hm2`` and ``sigma_rho_m`` together fix the model; ``train_s`` estimates the
missing ones, with the covariance scaled so that P_fa stays at or below nominal in
:data:`TRAINING_CONFIDENCE` of trainings (``inflation``); the fitted values are reported in ``noise``
and can be given back as ``h0``/``hm2``/``sigma_rho_m`` on the next run. ``n_skipped`` counts missing epochs and corrupt
frames.

Errors name the parameter (the config field, e.g. ``train_s``), which the command line writes as its
option, so the one message serves the library and the command.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.integrity.availability import (  # noqa: F401 (EXIT_CODES and the limits are part of this API)
    EXIT_CODES,
    MIN_TESTED_CHANNELS,
    MIN_TESTED_FRACTION,
    POSITION_TOLERANCE_M,
    SHORT_TRAINING_DIFFERENCES,
    availability,
    overall_state,
    training_warnings,
)
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.document import base_document, check_length, detection_document
from chronofuse.integrity.inputs import (  # noqa: F401 (re-exported: the CLI and tests import them from here)
    EARTH_SURFACE_M,
    parse_position,
    read_noise_file,
)
from chronofuse.integrity.products import clock_product_document
from chronofuse.integrity.receiver_status import DEFAULT_MAX_TIME_ACC_S
from chronofuse.integrity.watch import TRAINING_CONFIDENCE, DetectionSettings, watch_record
from chronofuse.io.arrival import arrival_warnings
from chronofuse.io.clockbias import n_skipped, read_clock_bias
from chronofuse.io.formats import check_applies, sniff_format
from chronofuse.validation import InputDataError, InputError, check_choice, check_scalar
from chronofuse.progress import silent, stages

#: The modes of :func:`detect_file`.
MODES = ("detection", "identification")


def detect_record(record, settings: DetectionSettings) -> dict:
    """Detection mode on one gridded clock-bias record (:mod:`chronofuse.integrity.document`): the batch
    driver of the detection pipeline (:func:`chronofuse.integrity.watch.watch_record`) and its document.
    Raises :class:`InputDataError` naming the source when the record is shorter than one window."""
    check_length(record.n_epochs, settings.window, record.source)
    watched = watch_record(record, settings)
    doc = detection_document(watched, settings, n_skipped=n_skipped(record), time_scale=record.time_scale)
    doc["warnings"] += arrival_warnings(int(record.info.get("n_reordered", 0)), int(record.info.get("n_late", 0)))
    return doc


def detection_settings(detector: str = "chi-square", **fields) -> DetectionSettings:
    """The :class:`DetectionSettings` of ``fields`` watching with the detector ``detector`` of
    :data:`chronofuse.integrity.registry.DETECTORS` (the HOD chi-square test by default). Its settings are
    checked here, before any data is read (an unknown or inapplicable one is refused by name)."""
    if detector == "chi-square":
        return DetectionSettings(**fields)
    make = _detector_factory(detector, window=fields.get("window", 20), pfa=fields.get("pfa", 1e-3),
                             h0=fields.get("h0"), hm2=fields.get("hm2"), sigma_rho_m=fields.get("sigma_rho_m"),
                             confidence=TRAINING_CONFIDENCE if fields.get("train_s") is not None else None)
    return DetectionSettings(**fields, detector=lambda interval_s, _settings: make(interval_s))


def position_offsets_m(obs, nav, position_m: np.ndarray) -> np.ndarray:
    """Per epoch of ``obs`` (:class:`chronofuse.io.rinex.GpsObservations`), the median over the epochs so far
    (causal) of the distance (m) between the data's own single-point fix
    (:func:`chronofuse.gnss.spp.single_point_position`) and ``position_m`` (NaN: no fix yet)."""
    from chronofuse.gnss.spp import single_point_position

    pos, _, _ = single_point_position(obs, nav)
    dist = np.linalg.norm(pos - position_m[None, :], axis=1)
    out = np.full(dist.size, np.nan)
    for k in range(dist.size):
        seen = dist[: k + 1][np.isfinite(dist[: k + 1])]
        if seen.size:
            out[k] = float(np.median(seen))
    return out


def identification_document(obs: str | Path, nav: str | Path, position_m, detector: HodDetector,
                            train_s: float | None = None) -> dict:
    """Identification mode on a RINEX observation file with its navigation file and antenna position.

    Every code observable of the file is tested (a fault on P2 was invisible when only C1
    was): with one code, channels are named by satellite (``G20``); with several, by satellite and code
    (``G20 C1``, ``G20 P2``). Per epoch, the state is ``ok`` when at least :data:`MIN_TESTED_CHANNELS`
    channels of the L1 code (the one a position/time solution uses) are tested and the position check
    passes, ``alarm`` while a channel of any code is faulty: raised when identification names it, cleared
    when it is consistent with the others again (:mod:`chronofuse.integrity.channel_latch`; each raise and
    clear is in ``channel_events`` with its reason). Returns the document of
    :func:`detect_file` with ``faulty`` (channels named, with the time each was named), ``untested``
    (channels never tested), ``codes`` and the states of the module docstring.
    """
    # imported here: the RINEX stack (georinex, xarray) takes a second to import, detection mode needs none of it
    from chronofuse.integrity.channel_latch import latch_channels
    from chronofuse.integrity.identification import identify
    from chronofuse.io.rinex import channel_clock_biases, read_gps_navigation, read_gps_observations

    position = parse_position(position_m)
    observations = read_gps_observations(obs)
    navigation = read_gps_navigation(nav)
    codes = observations.codes
    runs = []
    for code in codes:
        biases = channel_clock_biases(obs, nav, position, code=code, observations=observations, navigation=navigation)
        if not runs:
            interval_s = float(biases.interval_s)
            detector.interval_s = interval_s  # the file's own interval
            n_epochs = int(np.asarray(biases.t_s).size)
            check_length(n_epochs, detector.window, str(obs))
            options = {}
            n_train = 0
            if train_s is not None:
                # each channel's noise fitted on its own first valid epochs of the training length
                options["train_epochs"] = max(3, int(round(train_s / interval_s)))
                n_train = min(options["train_epochs"], n_epochs)
        runs.append((code, identify(biases, detector, **options), biases))
    label = (lambda sat, code: sat) if len(codes) == 1 else (lambda sat, code: f"{sat} {code}")
    step_ns = int(round(interval_s * 1e9))
    # absolute GPS ns of the grid epochs (as RINEX 3's station mode gives them); "t" is seconds since the first
    t_ns = int(observations.gps_ns[0]) + np.arange(n_epochs, dtype=np.int64) * step_ns
    t_s = (t_ns - t_ns[0]) / 1e9
    offsets = position_offsets_m(observations, navigation, position)
    slots = np.round((observations.gps_ns - observations.gps_ns[0]) / step_ns).astype(np.int64)
    offset_at = np.full(n_epochs, np.nan)
    offset_at[np.clip(slots, 0, n_epochs - 1)] = offsets
    offset_at = _forward_fill(offset_at)
    far = offset_at > POSITION_TOLERANCE_M
    tested = runs[0][1].tested.sum(axis=1)
    latched = np.zeros(n_epochs, dtype=bool)
    channel_events = []
    for code, result, _ in runs:
        mask, events = latch_channels(result)
        latched |= mask.any(axis=1)
        channel_events += [{"t_ns": int(t_ns[e.epoch]), "t": float(t_s[e.epoch]), "channel": label(e.channel, code),
                            "kind": e.kind, "reason": e.reason} for e in events]
    states = np.full(n_epochs, "unavailable", dtype=object)
    states[(tested >= MIN_TESTED_CHANNELS) & ~far] = "ok"
    states[latched] = "alarm"
    per_epoch = np.full(n_epochs, "", dtype=object)
    per_epoch[tested < MIN_TESTED_CHANNELS] = f"fewer than {MIN_TESTED_CHANNELS} channels tested"
    per_epoch[:n_train] = "training"
    per_epoch[far] = f"position more than {POSITION_TOLERANCE_M:g} m from the data's own fix"
    reasons: list[str] = []
    if np.isfinite(offset_at).any() and np.nanmax(offset_at) > POSITION_TOLERANCE_M:
        reasons.append(f"the position given is {np.nanmax(offset_at):.0f} m from the data's own single-point fix "
                       f"(tolerance {POSITION_TOLERANCE_M:g} m)")
    if runs[0][1].untested == runs[0][1].satellites:
        reasons.append("no channel could be tested (too few epochs above the elevation mask, or no ephemeris "
                       "for these epochs in the navigation file)")
    state = overall_state(states, n_train, reasons, present=np.isfinite(runs[0][2].bias_s).any(axis=1))
    alarms, faulty, untested = [], [], []
    for code, result, _ in runs:
        alarms += [{"t_ns": int(t_ns[a["epoch"]]), "t": float(t_s[a["epoch"]]), "statistic": a["statistic"],
                    "channel": label(a["channel"], code)} for a in result.alarms]
        faulty += [{"channel": label(ch, code), "t_ns": int(t_ns[result.blamed_at[result.satellites.index(ch)]]),
                    "t": float(t_s[result.blamed_at[result.satellites.index(ch)]])} for ch in result.faulty]
        untested += [label(ch, code) for ch in result.untested]
    alarms.sort(key=lambda a: (a["t_ns"], a["channel"]))
    faulty.sort(key=lambda f: (f["t_ns"], f["channel"]))
    doc = base_document("identification", n_epochs, detector.window, detector.pfa, alarms,
                        int(runs[0][1].n_skipped_epochs))
    doc.update(availability(state, reasons, t_ns, per_epoch, states, n_train))
    doc["faulty"] = faulty
    doc["channel_events"] = sorted(channel_events, key=lambda e: (e["t_ns"], e["channel"]))
    doc["untested"] = untested
    doc["codes"] = codes
    doc["interval_s"] = interval_s
    doc["t0_gps_ns"] = int(t_ns[0])
    return doc


def _rinex_version(path) -> float:
    """The RINEX version of an observation file from its first line (a Hatanaka file's CRINEX 3 holds RINEX 3,
    CRINEX 1 RINEX 2); 0 when unreadable."""
    from chronofuse.io.rinex_text import first_line

    line = first_line(path)
    try:
        version = float(line[:9])
    except ValueError:
        return 0.0
    return (3.0 if version >= 3 else 2.0) if "CRINEX" in line else version


def _station_mode(path, nav, position_m, *, train_s, window, pfa, test, codes, elevation_mask_deg, progress) -> dict:
    """A RINEX 3 file: every code of every system through the station's identification
    (:func:`chronofuse.integrity.station_mode.station_document`); ``nav`` the navigation file(s), merged. The
    settings are checked before any file is read."""
    from chronofuse.integrity.station_mode import station_document
    from chronofuse.io.rinex_nav import merge_navigation, read_navigation
    from chronofuse.io.station_channels import station_channels

    from chronofuse.integrity.window_tests import WINDOW_TESTS
    from chronofuse.io.rinex_obs import read_any_observations

    check_choice(test, "test", WINDOW_TESTS)
    check_scalar(elevation_mask_deg, "elevation_mask_deg", min_val=0.0, max_val=90.0, include_max=False)
    if train_s is None:
        raise InputError("a RINEX 3 station needs a training stretch ({train_s}): each code's noise is fitted on it",
                         str(path), fields=("train_s",))
    position = parse_position(position_m)
    # shares measured on a day at 30 s (ESBC00DNK, RINEX 3 Hatanaka, 263 s on a loaded machine): observations
    # 4.3 %, navigation 0.4 %, channels (orbits, elevations) 3.2 %, the station's identification the rest
    obs_stage, nav_stage, channel_stage, station_stage = stages(progress, (0.043, 0.004, 0.032, 0.921))
    obs_stage(f"reading {Path(path).name}")
    observations = read_any_observations(path)
    nav_stage("reading the navigation")
    navigation = merge_navigation([read_navigation(p) for p in nav])
    channel_stage("orbits and elevations of every channel")
    channels = station_channels(observations, navigation, position, codes=codes, elevation_mask_deg=elevation_mask_deg)
    return station_document(None, None, position, channels=channels, train_s=train_s, window=window, pfa=pfa,
                            test=test, progress=station_stage)


def _raim_mode(path, nav, position_m, settings, elevation_mask_deg: float) -> dict:
    """``raim``: position-domain integrity of a RINEX observation file whose position need not be known
    (:mod:`chronofuse.integrity.raim_station`; a position given is used only to check the levels)."""
    from chronofuse.integrity.raim_station import raim_document

    if sniff_format(path) != "rinex-obs":
        raise InputError("{raim} needs a RINEX observation file (pseudoranges) with its navigation file ({nav})",
                         str(path), fields=("raim", "nav"))
    if nav is None:
        raise InputError("{raim} needs the navigation file ({nav}) of the observation file", str(path),
                         fields=("raim", "nav"))
    check_scalar(elevation_mask_deg, "elevation_mask_deg", min_val=0.0, max_val=90.0, include_max=False)
    navs = [nav] if isinstance(nav, (str, Path)) else list(nav)
    return raim_document(path, navs, settings=settings, position_m=position_m, elevation_mask_deg=elevation_mask_deg)


def _forward_fill(values: np.ndarray) -> np.ndarray:
    idx = np.where(np.isfinite(values), np.arange(values.size), 0)
    idx = np.maximum.accumulate(idx)
    return values[idx]


def detect_file(
    path: str | Path,
    rate_hz: float | None = None,
    *,
    column: str | None = None,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
    train_s: float | None = None,
    window: int = 20,
    pfa: float = 1e-3,
    position_m=None,
    nav: str | Path | list | None = None,
    station: str | None = None,
    max_time_acc_s: float | None = DEFAULT_MAX_TIME_ACC_S,
    detector: str = "chi-square",
    test: str = "chi-square",
    codes=None,
    elevation_mask_deg: float = 10.0,
    raim: bool = False,
    raim_settings=None,
    progress=None,
) -> dict:
    """Clock-bias anomaly detection on a file, the mode chosen from the file (module docstring).

    Parameters
    ----------
    path : str or Path
        Clock-bias CSV, UBX capture or RINEX observation file.
    rate_hz : float, optional
        Sampling rate (Hz) of a file without a time column; a file's own times give its interval.
    column : str, optional
        The CSV clock-bias column.
    h0, hm2, sigma_rho_m : float, optional
        White FM level (s), random-walk FM level (1/s), mean pseudorange noise (m).
    train_s : float, optional
        Learn the missing noise parameters from the first ``train_s`` seconds (not tested). Either all
        three noise parameters or ``train_s`` are required.
    window : int
        Window length n (epochs).
    pfa : float
        False-alarm probability per epoch.
    position_m : str or array-like of shape (3,), optional
        Static antenna ECEF X, Y, Z (m), for identification mode.
    nav : str or Path, or a list of them, optional
        RINEX navigation file, for identification mode: one for a RINEX 2 observation file; a RINEX 3 file
        takes several (merged: a day that spans two navigation files).
    station : str, optional
        For a RINEX clock product (``.clk``): the station whose ``AR`` clock is tested (detection mode);
        without it every station is tested (:func:`chronofuse.integrity.products.clock_product_document`).
    max_time_acc_s : float or None
        Largest receiver time accuracy estimate (s; UBX NAV-CLOCK tAcc) of an epoch to be tested; None: not
        used (:mod:`chronofuse.integrity.receiver_status`).
    detector : str
        A name of :data:`chronofuse.integrity.registry.DETECTORS` (plugins included) for detection mode;
        ``window`` and ``confidence`` go to a detector that has them, ``h0``/``hm2``/``sigma_rho_m`` when
        given. Identification mode and the all-stations table of a clock product run the chi-square test.

    test : str
        RINEX 3 observations: the window test of every channel, ``"chi-square"`` or ``"glr"``
        (:mod:`chronofuse.integrity.window_tests`).
    codes : sequence of str, optional
        RINEX 3 observations: the codes tested (``"G C1C"``); default every code most satellites carry.
    elevation_mask_deg : float
        RINEX 3 observations: channels below this elevation are not used.
    progress : callable, optional
        ``progress(message, fraction)`` (:mod:`chronofuse.progress`): the stage and the fraction done, for a
        RINEX 3 station (the long one: minutes for a day); other modes say nothing.

    Returns
    -------
    dict
        ``mode`` ("detection" or "identification"), ``state`` ("ok", "alarm" or "unavailable"; exit code
        in :data:`EXIT_CODES`), ``unavailable_reasons``, ``unavailable`` (untested stretches), ``n_epochs``,
        ``n_tested``, ``n_training``, ``interval_s``, ``threshold`` (for a full window), ``window``, ``pfa``,
        ``alarms`` (each ``{"t_ns", "t", "statistic", "channel"}``), ``n_alarms``, ``n_skipped``; detection
        adds ``clock_events`` (each ``{"t_ns", "t", "size_s", "kind"}``), ``noise`` (the model used) and
        ``warnings`` (:func:`training_warnings`);
        identification adds ``faulty``, ``channel_events`` and ``untested``; a clock product without ``station``
        gives :func:`chronofuse.integrity.products.clock_product_document`.
    """
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    if raim:
        return _raim_mode(path, nav, position_m, raim_settings, elevation_mask_deg)
    if train_s is not None:
        check_scalar(train_s, "train_s", min_val=0.0, include_min=False)
    elif None in (h0, hm2, sigma_rho_m):
        raise InputError("give the noise model ({h0}, {hm2} and {sigma_rho_m}) or a training stretch ({train_s})",
                         fields=("h0", "hm2", "sigma_rho_m", "train_s"))
    kind = sniff_format(path)
    if kind == "rinex-nav":
        raise InputError("this is a RINEX navigation file: give the observation file, and this one as {nav}", str(path),
                         fields=("nav",))
    check_applies(kind, str(path), column=column, rate_hz=rate_hz, codes=codes or None)
    if kind == "rinex-obs":
        _only_chi_square(detector, "identification mode (a RINEX observation file)")
        if nav is None or position_m is None:
            raise InputError("a RINEX observation file needs a navigation file ({nav}) and the antenna position "
                             "({position_m}, ECEF X,Y,Z) for identification mode", str(path), fields=("nav", "position_m"))
        navs = [nav] if isinstance(nav, (str, Path)) else list(nav)
        if _rinex_version(path) >= 3:
            return _station_mode(path, navs, position_m, train_s=train_s, window=window,
                                 pfa=pfa, test=test, codes=codes, elevation_mask_deg=elevation_mask_deg,
                                 progress=progress or silent)
        params = dict(window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m,
                      confidence=TRAINING_CONFIDENCE if train_s is not None else None)
        if len(navs) != 1:
            raise InputError(f"a RINEX 2 observation file takes one navigation file ({{nav}}), not {len(navs)}",
                             str(path), fields=("nav",))
        return identification_document(path, navs[0], position_m, HodDetector(interval_s=1.0, **params), train_s)
    if nav is not None or position_m is not None:
        raise InputError("{nav} and {position_m} need a RINEX observation file (identification mode)", str(path),
                         fields=("nav", "position_m"))
    if max_time_acc_s is not None:
        check_scalar(max_time_acc_s, "max_time_acc_s", min_val=0.0, include_min=False)
    settings = detection_settings(detector, window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m,
                                  train_s=train_s, max_time_acc_s=max_time_acc_s)
    if kind == "rinex-clock":
        from chronofuse.io.rinex_clock import read_station_clocks, station_clock_bias

        clocks = read_station_clocks(path)
        if station is None:
            _only_chi_square(detector, "the table of every station of a clock product (give {station})", ("station",))
            return clock_product_document(clocks, settings)
        doc = detect_record(station_clock_bias(clocks, station), settings)
        doc["station"] = station
        return doc
    from chronofuse.io.formats import log_format

    if station is not None and log_format(path) is None:
        raise InputError("{station} needs a RINEX clock product (.clk) or a field log with several clocks",
                         str(path), fields=("station",))
    return detect_record(read_clock_bias(path, rate_hz, column, clock=station), settings)


def _only_chi_square(detector: str, where: str, fields: tuple[str, ...] = ()) -> None:
    if detector != "chi-square":
        raise InputError(f"{{detector}} == {detector!r}: {where} runs the chi-square test only",
                         fields=("detector", *fields))


def _detector_factory(name: str, *, window, pfa, h0, hm2, sigma_rho_m, confidence):
    """``make(interval_s)`` building the detector ``name`` of the registry for one clock bias (see
    :func:`detect_file`); refuses a detector that needs another input, or a noise parameter it does not take."""
    from chronofuse.integrity.registry import DETECTORS

    entry = DETECTORS.entry(name)
    needs = tuple(getattr(entry.target, "inputs", ()))
    if needs:
        raise InputError(f"{{detector}} == {name!r} needs the input(s) {list(needs)}; a clock-bias file "
                         "gives one clock bias", fields=("detector",))
    fields = entry.config.model_fields
    settings = {"pfa": pfa}
    for key, value in (("window", window), ("confidence", confidence)):
        if key in fields and value is not None:
            settings[key] = value
    for key, value in (("h0", h0), ("hm2", hm2), ("sigma_rho_m", sigma_rho_m)):
        if value is not None:
            settings[key] = value  # refused by the registry, naming it, if the detector has no such setting
    DETECTORS.config(name, **settings)  # check the settings before any file is read

    def make(interval_s: float):
        return DETECTORS.create(name, context={"interval_s": interval_s}, **settings)

    return make
