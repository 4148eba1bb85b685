"""When integrity is available: the per-epoch and overall states of :mod:`chronofuse.integrity.modes`, the
untested stretches, the exit codes, and the screen of a training stretch.

``ok``: tested, no fault; ``alarm``: a fault (latched); ``unavailable``: integrity could not be tested.
The rules are in :mod:`chronofuse.integrity.modes`' docstring; the numbers here are their parameters.
"""

from __future__ import annotations

import numpy as np

#: Exit status of ``chronofuse detect`` for each overall state (2 is bad input, :mod:`chronofuse.cli.common`).
EXIT_CODES = {"ok": 0, "alarm": 1, "unavailable": 3}

#: Fewest channels with a verdict for an identification epoch to be tested (three for the others' clock).
MIN_TESTED_CHANNELS = 4

#: Fewest share of the epochs after training that must be tested for the record's integrity to be available.
MIN_TESTED_FRACTION = 0.5

#: Largest distance (m) between the position given and the data's own single-point fix (median over the
#: epochs so far): the fix of the two Trimble stations is within 5.3 m of their header position at every
#: epoch; 1 km off makes healthy channels alarm.
POSITION_TOLERANCE_M = 50.0

#: Fewer training differences than this: a warning (the P_fa margin is then large, see ``noise.inflation``).
SHORT_TRAINING_DIFFERENCES = 100


def training_warnings(df: np.ndarray) -> list[str]:
    """Warnings on a training stretch's second differences ``df`` (NaN = missing): too short
    (< :data:`SHORT_TRAINING_DIFFERENCES`), or not stationary: the mean squares of its two halves differ
    beyond the two-sided 0.1 % F test, its degrees of freedom ``m / (1 + 2 (rho1^2 + rho2^2))`` for the
    MA(2) differences (Bartlett's variance of a mean square of a correlated series; a screen, not an
    exact test)."""
    from scipy import stats

    d = df[np.isfinite(df)]
    out = []
    if d.size < SHORT_TRAINING_DIFFERENCES:
        out.append(f"short training: {d.size} differences (< {SHORT_TRAINING_DIFFERENCES}); the threshold's "
                   "margin for the noise estimate is large")
    half = d.size // 2
    if half >= 8:
        a, b = d[:half], d[half:]
        ratio = float(np.mean(a**2) / np.mean(b**2))
        # MA(2): a mean square of m differences has the variance of m / (1 + 2 (rho1^2 + rho2^2)) independent ones
        r0 = float(np.mean(d**2))
        rho = [float(np.mean(d[k:] * d[:-k])) / r0 for k in (1, 2)]
        shrink = 1.0 + 2.0 * (rho[0] ** 2 + rho[1] ** 2)
        lo, hi = stats.f.ppf([0.0005, 0.9995], a.size / shrink, b.size / shrink)
        if not lo <= ratio <= hi:
            out.append(f"training not stationary: the second half's difference variance is {1 / ratio:.3g} times "
                       "the first half's")
    return out


def _intervals(t_ns: np.ndarray, reasons: np.ndarray) -> list[dict]:
    """Runs of equal non-empty ``reasons`` (per epoch) as ``{"from_ns", "to_ns", "reason"}``."""
    out = []
    k = 0
    n = reasons.size
    while k < n:
        if not reasons[k]:
            k += 1
            continue
        j = k
        while j + 1 < n and reasons[j + 1] == reasons[k]:
            j += 1
        out.append({"from_ns": int(t_ns[k]), "to_ns": int(t_ns[j]), "reason": str(reasons[k])})
        k = j + 1
    return out


def overall_state(states: np.ndarray, training: int, reasons: list[str], present=None) -> str:
    """The record's state from its per-epoch ``states`` (module docstring); appends to ``reasons``.

    ``present`` (bool per epoch): epochs with data; the share tested is counted over those after training,
    so a long gap (missing epochs, reported in ``unavailable``) does not make the rest of the record
    unavailable (a 1 h 45 min gap made a whole GRG clock file unusable)."""
    after = states[training:]
    if present is not None:
        after = after[np.asarray(present, dtype=bool)[training:]]
    tested = int(np.isin(after, ("ok", "alarm")).sum())
    if after.size == 0 or tested < MIN_TESTED_FRACTION * after.size:
        reasons.append(f"{tested} of {after.size} epochs with data after training tested "
                       f"(need {MIN_TESTED_FRACTION:.0%})")
    if reasons:
        return "unavailable"
    return "alarm" if (states == "alarm").any() else "ok"


def availability(state: str, reasons: list[str], t_ns, per_epoch, states, n_train: int) -> dict:
    """The availability keys of a detect document: ``state``, ``unavailable_reasons``, ``n_tested``,
    ``n_training`` and ``unavailable`` (the untested stretches with the reason of each, from ``per_epoch``)."""
    return {
        "state": state,
        "unavailable_reasons": reasons,
        "n_tested": int(np.isin(states, ("ok", "alarm")).sum()),
        "n_training": int(n_train),
        "unavailable": _intervals(np.asarray(t_ns), np.where(np.isin(states, ("ok", "alarm")), "", per_epoch)),
    }
