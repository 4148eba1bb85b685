"""Source qualification (the GNSSDO paper section 3.2 (1) ①): is a receiver's 1PPS usable this second?

The source paper: "judge from the receiver's NMEA messages whether it has received enough satellites and
completed positioning and timing; if it has, and the GDOP of the satellites used is below 5, the 1PPS
is usable, otherwise not." Here, per receiver epoch:

    usable = fix  and  time_valid  and  n_sats >= min_sats  and  GDOP < gdop_max  and  1PPS present

``GDOP < gdop_max`` is strict as in the source paper ("小于 5"); a missing GDOP (NaN) is never usable. The
threshold is configurable (>= 1: GDOP is never below 1, so a smaller threshold would refuse every
epoch and is rejected as a configuration error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.epochs import ReceiverEpochs
from chronofuse.validation import check_scalar

__all__ = ["Qualification", "usable_epochs"]


@dataclass(frozen=True)
class Qualification:
    """Thresholds of the usability test.

    Parameters
    ----------
    gdop_max : float
        A 1PPS is usable only when GDOP < ``gdop_max`` (seed: 5). Must be >= 1.
    min_sats : int
        Fewest satellites in the solution (a time fix needs 4 for an unknown position; >= 1).
    """

    gdop_max: float = 5.0
    min_sats: int = 4

    def __post_init__(self):
        check_scalar(self.gdop_max, "gdop_max", min_val=1.0)
        check_scalar(self.min_sats, "min_sats", min_val=1, integer=True)

    def usable(self, fix, time_valid, gdop, n_sats, pps_present=None) -> np.ndarray:
        """Boolean mask of usable epochs; all inputs broadcast to one shape (e.g. (trials, receivers, steps)).

        ``fix``, ``time_valid`` (bool), ``gdop`` (float, NaN = unknown), ``n_sats`` (int),
        ``pps_present`` (bool, optional: whether a 1PPS edge was measured this second).
        """
        gdop = np.asarray(gdop, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            good_gdop = np.isfinite(gdop) & (gdop < self.gdop_max)
        ok = np.asarray(fix, dtype=bool) & np.asarray(time_valid, dtype=bool) & good_gdop
        ok = ok & (np.asarray(n_sats) >= self.min_sats)
        if pps_present is not None:
            ok = ok & np.asarray(pps_present, dtype=bool)
        return ok


def usable_epochs(epochs: ReceiverEpochs, qualification: Qualification = Qualification(), pps_present=None) -> np.ndarray:
    """Usable mask of receiver epochs (simulated or read), shape (trials, receivers, epochs).

    Fix: ``epochs.has_fix`` (a 2-D or 3-D / time-only fix); time: ``epochs.time_valid``; GDOP and
    satellites from the epochs. ``pps_present`` (same shape, optional): whether a 1PPS edge was
    measured (a simulated run passes ``numpy.isfinite(truth.pps_error_s)``).
    """
    if not isinstance(epochs, ReceiverEpochs):
        raise TypeError(f"epochs == {epochs!r}, must be a ReceiverEpochs")
    return qualification.usable(epochs.has_fix, epochs.time_valid, epochs.gdop, epochs.n_sats, pps_present)
