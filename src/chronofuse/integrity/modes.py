"""Clock-bias integrity on a data file: the mode chosen from what the file provides (SPEC 4).

:func:`detect_file` is what ``chronofuse detect FILE`` does, as a library call that returns the same
document the command prints with ``--json``:

* a CSV (time and clock-bias columns) or a u-blox UBX capture (NAV-CLOCK ``clkB``) gives one receiver clock
  bias (:func:`chronofuse.io.clockbias.read_clock_bias`): **detection** mode, one
  :class:`~chronofuse.integrity.detector.HodDetector` over the record;
* a RINEX observation file with a navigation file and the static antenna's ECEF position gives
  per-satellite clock biases: **identification** mode
  (:func:`chronofuse.integrity.identification.identify`: the common receiver clock removed, each channel's
  noise fitted on its own first ``train_s`` seconds; an alarm names its satellite).

Noise parameters: ``h0``, ``hm2`` and ``sigma_rho_m`` together fix the model; ``train_s`` estimates the
missing ones from the first ``train_s`` seconds of the record (assumed anomaly-free; the test then runs over
the whole record). Alarm times ``t`` are seconds on the file's time axis (the time column for CSV, GPS time of
week for UBX, seconds from the first epoch for RINEX). ``n_skipped`` counts missing epochs and corrupt frames.

Errors name the command-line option beside the parameter (``train_s (--train)``) so the one message serves
the library and the command.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from chronofuse.integrity.detector import HodDetector, chi2_thresholds
from chronofuse.io.clockbias import ClockBiasInput, read_clock_bias
from chronofuse.io.formats import sniff_format
from chronofuse.validation import InputDataError, check_scalar

#: The modes of :func:`detect_file`.
MODES = ("detection", "identification")

# Geocentric radius of a static receiver: the WGS 84 polar radius minus the Dead Sea shore, to the
# equatorial radius plus a high mountain (metres).
EARTH_SURFACE_M = (6_350_000.0, 6_390_000.0)


def parse_position(position) -> np.ndarray:
    """A static antenna's ECEF position (3,) in metres from ``"X,Y,Z"`` text or three numbers.

    Raises :class:`InputDataError` when it is not three finite numbers or lies outside
    :data:`EARTH_SURFACE_M` from the Earth's centre (degrees or kilometres given by mistake).
    """
    text = position if isinstance(position, str) else ",".join(map(str, np.ravel(position)))
    try:
        xyz = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise InputDataError(f"--position {text!r}: expected X,Y,Z in ECEF metres") from None
    if xyz.shape != (3,) or not np.isfinite(xyz).all():
        raise InputDataError(f"--position {text!r}: expected three finite numbers X,Y,Z (ECEF metres)")
    radius_m = float(np.linalg.norm(xyz))
    lo_m, hi_m = EARTH_SURFACE_M
    if not lo_m <= radius_m <= hi_m:
        raise InputDataError(f"--position {text!r}: {radius_m / 1e3:.1f} km from the Earth's centre, must be a static "
                             f"receiver near the surface ({lo_m / 1e3:.0f}..{hi_m / 1e3:.0f} km; "
                             "ECEF metres, not degrees or km)")
    return xyz


def _check_length(n_epochs: int, window: int, source: str) -> None:
    if n_epochs - 2 < window:
        raise InputDataError(f"window {window} is longer than the data: {n_epochs} epochs give {max(n_epochs - 2, 0)} "
                             "differences", source)


def _fit(det: HodDetector, data: ClockBiasInput, train_s: float | None) -> HodDetector:
    """Fit ``det`` on its given model, or on the epochs within ``train_s`` of the first one."""
    if train_s is None:
        return det.fit()
    rows = slice(0, int(np.searchsorted(data.t_s - data.t_s[0], train_s, side="left")))
    training = data.bias_s[rows]
    n_valid = int(np.isfinite(training).sum())
    if n_valid < det.window + 3:
        raise InputDataError(f"train_s (--train) {train_s:g} s holds {n_valid} valid epochs; need at least "
                             f"window + 3 = {det.window + 3}", data.source)
    return det.fit(training)


def detection_document(data: ClockBiasInput, detector: HodDetector, train_s: float | None = None) -> dict:
    """Detection mode on one clock bias: fit ``detector`` (on its model or the first ``train_s`` s), run it.

    ``detector`` is fitted in place (scikit-learn style). Returns the document of :func:`detect_file`.
    """
    _check_length(data.bias_s.size, detector.window, data.source)
    _fit(detector, data, train_s)
    res = detector.run(data.bias_s)
    alarms = [{"t": float(data.t_s[k]), "statistic": float(res.statistic[k]), "channel": None}
              for k in np.flatnonzero(res.alarm)]
    return _document("detection", data.bias_s.size, detector, alarms, data.n_skipped)


def identification_document(obs: str | Path, nav: str | Path, position_m, detector: HodDetector,
                            train_s: float | None = None) -> dict:
    """Identification mode on a RINEX observation file with its navigation file and antenna position.

    Returns the document of :func:`detect_file` with ``faulty`` (channels named, with the time each was
    named) and ``untested`` (channels with too few epochs above the elevation mask).
    """
    # imported here: the RINEX stack (georinex, xarray) takes a second to import, detection mode needs none of it
    from chronofuse.integrity.identification import identify
    from chronofuse.io.rinex import channel_clock_biases

    biases = channel_clock_biases(obs, nav, parse_position(position_m))
    interval_s = float(biases.interval_s)
    if not math.isclose(interval_s, detector.interval_s, rel_tol=1e-6):
        raise InputDataError(f"observation interval {interval_s:g} s does not match rate_hz (--rate) "
                             f"({detector.interval_s:g} s): a new interval needs a new detector", str(obs))
    n_epochs = int(np.asarray(biases.t_s).size)
    _check_length(n_epochs, detector.window, str(obs))
    options = {}
    if train_s is not None:
        # each channel's noise fitted on its own first valid epochs of the training length
        options["train_epochs"] = max(3, int(round(train_s / interval_s)))
    result = identify(biases, detector, **options)
    n_skipped = int(result.n_skipped_epochs)  # grid epochs not read, unreadable ones included
    doc = _document("identification", n_epochs, detector, result.alarms, n_skipped)
    doc["faulty"] = [{"channel": ch, "t": float(result.first_blame_s[result.satellites.index(ch)])}
                     for ch in result.faulty]
    doc["untested"] = result.untested
    return doc


def detect_file(
    path: str | Path,
    rate_hz: float,
    *,
    column: str | None = None,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
    train_s: float | None = None,
    window: int = 20,
    pfa: float = 1e-3,
    position_m=None,
    nav: str | Path | None = None,
) -> dict:
    """Clock-bias anomaly detection on a file, the mode chosen from the file (module docstring).

    Parameters
    ----------
    path : str or Path
        Clock-bias CSV, UBX capture or RINEX observation file.
    rate_hz : float
        Sampling rate of the clock bias (Hz); a file on another interval is an error.
    column : str, optional
        The CSV clock-bias column.
    h0, hm2, sigma_rho_m : float, optional
        White FM level (s), random-walk FM level (1/s), mean pseudorange noise (m).
    train_s : float, optional
        Learn the missing noise parameters from the first ``train_s`` seconds. Either all three noise
        parameters or ``train_s`` are required.
    window : int
        Window length n (epochs).
    pfa : float
        False-alarm probability per epoch.
    position_m : str or array-like of shape (3,), optional
        Static antenna ECEF X, Y, Z (m), for identification mode.
    nav : str or Path, optional
        RINEX navigation file, for identification mode.

    Returns
    -------
    dict
        ``mode`` ("detection" or "identification"), ``n_epochs``, ``threshold`` (for a full window),
        ``window``, ``pfa``, ``alarms`` (each ``{"t", "statistic", "channel"}``), ``n_alarms``, ``n_skipped``;
        identification adds ``faulty`` and ``untested``.
    """
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    if train_s is not None:
        check_scalar(train_s, "train_s", min_val=0.0, include_min=False)
    elif None in (h0, hm2, sigma_rho_m):
        raise ValueError("give the noise model (h0, hm2 and sigma_rho_m) or a training stretch (train_s)")
    kind = sniff_format(path)
    detector = HodDetector(interval_s=1.0 / rate_hz, window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m)
    if kind == "rinex-nav":
        raise InputDataError("this is a RINEX navigation file: give the observation file and --nav NAVFILE", str(path))
    if kind == "rinex-obs":
        if nav is None or position_m is None:
            raise InputDataError("a RINEX observation file needs --nav NAVFILE and --position X,Y,Z (identification "
                                 "mode: nav and position_m)", str(path))
        return identification_document(path, nav, position_m, detector, train_s)
    if nav is not None or position_m is not None:
        raise InputDataError("--nav/--position need a RINEX observation file (identification mode)", str(path))
    return detection_document(read_clock_bias(path, rate_hz, column), detector, train_s)


def _document(mode: str, n_epochs: int, det: HodDetector, alarms: list[dict], n_skipped: int) -> dict:
    return {
        "mode": mode,
        "n_epochs": int(n_epochs),
        "threshold": float(chi2_thresholds(det.pfa, int(det.window))[-1]),
        "window": int(det.window),
        "pfa": float(det.pfa),
        "alarms": alarms,
        "n_alarms": len(alarms),
        "n_skipped": int(n_skipped),
    }
