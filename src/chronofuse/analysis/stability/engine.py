"""The stability engine: one registry of statistics and one ``compute`` that serves them all.

``compute(statistic, x_s, rate_hz, tau_s)`` runs the same pipeline for every statistic:

1. validate the inputs (phase ``x_s`` 1-D in seconds, ``rate_hz > 0``, ``0 < ci < 1``);
2. handle gaps by the statistic's policy: ``skip`` passes NaN to a kernel that skips the terms the gap
   rule names (Allan and Hadamard families and TIE rms: ``"samples"``, a term whose own samples are
   missing, by default, or ``"span"``, one whose span holds a missing sample; MTIE: ``"window"``;
   ``skipped`` counts the missing samples); ``fill`` interpolates interior gaps linearly and trims
   leading/trailing ones first (total family and Theo1; ``filled`` counts them);
3. convert the averaging times (an array of seconds; ``taus.tau_grid`` builds the octave/decade/all
   grids) to averaging factors with ``taus_to_factors`` (a time that is not a whole multiple of the
   sample interval is an error; one beyond the record's range is dropped with a warning);
4. run the raw kernel and identify the noise (``noise_id``), side by side on two threads for records of
   :data:`SIDE_BY_SIDE_FROM` samples or more (both are numba loops that release the GIL, and each is a
   pure function of the record, so the result is the same as one after the other); multiply by the
   bias correction (``bias``) when asked; compute the EDF (``edf``; with gaps, from the terms actually
   used, :mod:`~chronofuse.analysis.stability.edf_gaps`) and the chi-square interval.

The result is a :class:`~chronofuse.analysis.stability.result.Deviation`.
"""

from __future__ import annotations

import os
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from pydantic import Field

from chronofuse.analysis.stability import edf as edf_mod
from chronofuse.analysis.stability import edf_tables
from chronofuse.analysis.stability.convert import fill_gaps
from chronofuse.analysis.stability.edf_gaps import edf_from_terms
from chronofuse.analysis.stability.kernels_differences import finite_sum, nan_prefix, term_validity
from chronofuse.analysis.stability.noise_id import identify_noise_methods
from chronofuse.analysis.stability.registry import EDF_FAMILIES, GAP_POLICIES, STATISTICS, StatisticSpec
from chronofuse.analysis.stability.result import Deviation
from chronofuse.analysis.stability.taus import taus_to_factors
from chronofuse.validation import InputError, check_array, check_choice, check_scalar
from chronofuse.registry import Config, Entry, Registry

__all__ = ["StatisticSpec", "STATISTICS", "compute", "kept_terms", "uncovered_samples", "GAP_POLICIES", "EDF_FAMILIES", "SIDE_BY_SIDE_FROM",
           "STATISTIC_REGISTRY", "Statistic", "StatisticConfig", "statistic_entry", "statistic_spec"]

#: Records at least this long have their kernel and their noise identification run on two threads: at
#: 1e7 points OADEV's kernel takes 0.15 s and the identification 0.08 s; below ~1e6 points a thread's
#: start-up is no longer small against either.
SIDE_BY_SIDE_FROM = 1 << 20


def _factors(spec: StatisticSpec, tau_s, rate_hz: float, n_points: int) -> np.ndarray:
    """Averaging factors (k,) for the averaging times ``tau_s`` (seconds), within the statistic's range."""
    max_m = int(spec.max_m(n_points))
    if isinstance(tau_s, str):
        raise TypeError(
            f"tau_s == {tau_s!r}: give averaging times in seconds as an array; "
            f"tau_grid({tau_s!r}, n_points, rate_hz, statistic) builds the standard grids"
        )
    if max_m < 1:
        raise InputError(f"x_s has {n_points} samples, too few for {spec.name}")
    taus = np.asarray(tau_s, dtype=float)
    if taus.ndim != 1 or taus.size == 0:
        raise ValueError(f"tau_s has shape {taus.shape}, must be a non-empty 1-D array of seconds")
    if not (np.isfinite(taus).all() and (taus > 0).all()):
        raise InputError(f"{{tau_s}} == {taus.tolist()}, must be positive finite seconds", fields=("tau_s",))
    m = taus_to_factors(taus, rate_hz, tau_factor=spec.tau_factor)  # its errors name tau_s
    if spec.m_step > 1 and (m % spec.m_step).any():
        bad = taus[m % spec.m_step != 0]
        raise InputError(
            f"{{tau_s}} == {bad.tolist()}, must be {spec.tau_factor} x even multiples of 1/rate_hz for {spec.name}",
            fields=("tau_s",))
    keep = m <= max_m
    if not keep.all():
        warnings.warn(
            f"tau_s {taus[~keep].tolist()} s dropped: beyond the largest {spec.name} averaging time "
            f"{spec.tau_factor * max_m / rate_hz} s for {n_points} samples",
            stacklevel=3,
        )
    m = m[keep]
    if m.size == 0:
        raise InputError(f"{{tau_s}} == {taus.tolist()}, no averaging time within the record's range for {spec.name}",
                         fields=("tau_s",))
    return m


def _phase(x_s) -> tuple[np.ndarray, int]:
    """``x_s`` as a float64 array (N,) and its number of missing (NaN) samples.

    One reduction vouches for a finite record (no NaN, no infinity); only a sum that is not finite
    sends the record through ``check_array`` (which rejects infinities and wrong shapes) and a count.
    """
    x = np.asarray(x_s, dtype=np.float64)
    if x.ndim == 1 and x.size and np.isfinite(finite_sum(x)):
        return x, 0
    x = check_array(x, "x_s", ndim=1, allow_nan=True)
    return x, int(np.count_nonzero(np.isnan(x)))


def _edf(spec: StatisticSpec, alpha: np.ndarray, m: np.ndarray, n_points: int) -> np.ndarray:
    """EDF (k,) of each factor by the statistic's family (NaN for ``none``), all factors in one call."""
    if spec.edf_family == "none":
        return np.full(m.size, np.nan)
    if spec.edf_family == "greenhall":
        d, overlapping, modified = edf_mod.GREENHALL_PARAMETERS[spec.name]
        return edf_mod.greenhall_edf(alpha, d, m, n_points, overlapping=overlapping, modified=modified)
    family = {"totdev": edf_tables.totdev_edf, "mtotdev": edf_tables.mtotdev_edf,
              "htotdev": edf_tables.htotdev_edf, "theo1": edf_tables.theo1_edf}[spec.edf_family]
    return family(alpha, m, n_points)


def kept_terms(statistic: str, x: np.ndarray, m: int, gap_rule: str) -> np.ndarray:
    """Which terms of a Greenhall-family statistic the gap rule keeps at factor ``m``: a boolean array over
    the term starts of the record without gaps (every sample, or every ``m``-th for ADEV and HDEV); an
    MDEV/TDEV term (``x[j .. j+3m-1]``) is kept when none of its samples is missing."""
    d, overlapping, modified = edf_mod.GREENHALL_PARAMETERS[statistic]
    if modified:
        c = nan_prefix(x)
        starts = np.arange(max(x.size - 3 * m + 1, 0))
        return c[starts + 3 * m] == c[starts]
    return term_validity(x, m, d, 1 if overlapping else m, gap_rule)


def uncovered_samples(statistic: str, x: np.ndarray, m: int, gap_rule: str = "samples") -> np.ndarray:
    """The samples present in ``x`` (N,) that no term the gap rule keeps at factor ``m`` spans (boolean (N,)).

    A term spans ``x[j .. j + 3m - 1]`` (MDEV, TDEV) or ``x[j .. j + d m]`` (the unmodified statistics). With
    gaps a stretch between two missing samples shorter than a term is seen by no term: an event there (a
    time-error burst next to a silence) is left out of the statistic, which then describes the rest of the
    record. Greenhall-family statistics only (those of :func:`kept_terms`).
    """
    d, overlapping, modified = edf_mod.GREENHALL_PARAMETERS[statistic]
    keep = kept_terms(statistic, x, int(m), gap_rule)
    step = 1 if (modified or overlapping) else int(m)
    starts = np.flatnonzero(keep) * step
    span = 3 * int(m) if modified else d * int(m) + 1
    edges = np.zeros(x.size + 1, dtype=np.int64)
    np.add.at(edges, starts, 1)
    np.add.at(edges, np.minimum(starts + span, x.size), -1)
    covered = np.cumsum(edges[:-1]) > 0
    return ~covered & ~np.isnan(x)


def _edf_with_gaps(spec: StatisticSpec, x: np.ndarray, alpha: np.ndarray, m: np.ndarray, gap_rule: str) -> np.ndarray:
    """Greenhall-family EDF (k,) from the terms the gap rule kept (:func:`edf_from_terms`)."""
    d, overlapping, modified = edf_mod.GREENHALL_PARAMETERS[spec.name]
    out = np.full(m.size, np.nan)
    for k, (a, mk) in enumerate(zip(alpha.tolist(), m.tolist())):
        if a + 2 * d > 1 and -4 <= a <= 2:
            out[k] = edf_from_terms(a, d, mk, kept_terms(spec.name, x, mk, gap_rule), overlapping=overlapping,
                                    modified=modified)
    return out


def _kernel_and_noise(spec: StatisticSpec, x: np.ndarray, x_id: np.ndarray, m: np.ndarray, tau0_s: float,
                      gap_rule: str, gaps: bool | None = None):
    """``(dev, n, (alpha, method))``: the statistic's kernel on ``x`` and the noise identification on
    ``x_id``, side by side for records of :data:`SIDE_BY_SIDE_FROM` samples or more on a machine with
    more than one CPU (the identification on a helper thread, the kernel in this one)."""
    kwargs = {"gap_rule": gap_rule} if len(spec.gap_rules) > 1 else {}
    if x.size < SIDE_BY_SIDE_FROM or (os.cpu_count() or 1) < 2:
        dev, n = spec.kernel(x, m, tau0_s, **kwargs)
        return dev, n, identify_noise_methods(x_id, m, spec.noise_dmax, spec.overlapping, gaps=gaps)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="chronofuse-noise-id") as pool:
        noise = pool.submit(identify_noise_methods, x_id, m, spec.noise_dmax, spec.overlapping, gaps=gaps)
        dev, n = spec.kernel(x, m, tau0_s, **kwargs)
        return dev, n, noise.result()


def compute(
    statistic: str,
    x_s,
    rate_hz: float,
    tau_s,
    *,
    ci: float = 0.683,
    bias_correction: bool = True,
    gap_rule: str | None = None,
) -> Deviation:
    """Compute a stability statistic of a phase record, with noise type, EDF and confidence interval.

    Parameters
    ----------
    statistic : str
        A key of ``STATISTICS``.
    x_s : array-like of shape (N,)
        Phase (time error) in seconds; NaN marks a missing sample. Frequency data must be converted
        first (``frequency_to_phase``).
    rate_hz : float
        Sample rate, ``1 / tau0``, > 0.
    tau_s : array-like of shape (k,)
        Averaging times in seconds (whole multiples of ``tau_factor/rate_hz``); ``tau_grid`` builds the
        octave, decade and all-factors grids.
    ci : float
        Confidence of the interval, 0 < ci < 1 (0.683: Stable32's 1 sigma).
    bias_correction : bool
        Apply the statistic's bias correction (TOTDEV, HTOTDEV), as Stable32 does.
    gap_rule : str, optional
        How missing samples remove terms, one of the statistic's ``gap_rules``: ``"samples"`` (the default
        of the Allan and Hadamard families and TIE rms: a term is skipped only when one of its own samples
        is missing) or ``"span"`` (when any sample it spans is; the right rule for phase integrated from
        frequency with gaps, where a phase difference across a missing frequency sample is unknown).
        MTIE has ``"window"``, the total family and Theo1 ``"fill"``.

    Returns
    -------
    Deviation
        All fields filled; ``tau_s``, ``dev``, ``n``, ``alpha``, ``edf``, ``lo``, ``hi`` of shape (k,).
    """
    if statistic in STATISTICS:
        spec = STATISTICS[statistic]
    else:  # a plugin's statistic, or an unknown name (refused, listing every name)
        spec = statistic_spec(statistic)
    if spec.combine is not None:  # a statistic made of others (TheoH): each part runs this pipeline
        check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
        return spec.combine(compute, _phase(x_s)[0], rate_hz, tau_s, ci=ci, bias_correction=bias_correction,
                            gap_rule=gap_rule)
    x, n_missing = _phase(x_s)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    check_scalar(ci, "ci", min_val=0, max_val=1, include_min=False, include_max=False)
    if not isinstance(bias_correction, (bool, np.bool_)):
        raise TypeError(f"bias_correction == {bias_correction!r}, must be a bool")
    tau0_s = 1.0 / rate_hz
    rule = spec.gap_rule if gap_rule is None else gap_rule
    if rule not in spec.gap_rules:
        raise ValueError(f"gap_rule == {gap_rule!r}, must be one of {list(spec.gap_rules)} for {statistic}")

    if n_missing == x.size:
        raise InputError(f"x_s has {x.size} samples, all NaN")
    skipped = filled = 0
    if spec.gaps == "fill":
        x, filled = fill_gaps(x)
        x_id = x
    else:
        skipped = n_missing
        x_id = x  # the identification reads the frequency averages the gaps leave
    n_points = int(x.size)  # after filling/trimming for the "fill" policy

    m = _factors(spec, tau_s, rate_hz, n_points)
    dev, n, (alpha, alpha_method) = _kernel_and_noise(spec, x, x_id, m, tau0_s, rule, gaps=bool(skipped))
    dev = np.asarray(dev, dtype=float)
    n = np.asarray(n, dtype=np.int64)
    corrected = bool(bias_correction and spec.bias is not None)
    if corrected:
        dev = dev * spec.bias(alpha, m, n_points)
    # With gaps skipped, the EDF comes from the terms actually used.
    if skipped and spec.edf_family == "greenhall":
        edf = _edf_with_gaps(spec, x, alpha, m, rule)
    else:
        edf = _edf(spec, alpha, m, n_points)
    lo, hi = edf_mod.chi2_interval(dev, edf, ci)
    return Deviation(
        statistic=statistic,
        tau_s=spec.tau_factor * m * tau0_s,
        dev=dev,
        n=n,
        alpha=alpha,
        alpha_method=alpha_method,
        edf=edf,
        lo=lo,
        hi=hi,
        ci=float(ci),
        bias_corrected=corrected,
        filled=int(filled),
        skipped=int(skipped),
        gap_rule=rule,
    )


# The family's registry (:mod:`chronofuse.analysis.stability.statistic_registry` re-exports it): here, beside
# compute, because a registered statistic is computed by it and the engine runs a plugin's statistic by name.
class StatisticConfig(Config):
    """What :func:`~chronofuse.analysis.stability.engine.compute` lets a caller choose for any statistic."""

    ci: float = Field(0.683, gt=0.0, lt=1.0, description="confidence of the interval (dimensionless)")
    bias_correction: bool = Field(True, description="apply the statistic's bias correction, as Stable32 does (bool)")


class Statistic:
    """One statistic with its settings: ``stat(x_s, rate_hz, tau_s)`` is ``compute(name, x_s, rate_hz, tau_s,
    ci=..., bias_correction=...)`` (a :class:`~chronofuse.analysis.stability.result.Deviation`)."""

    def __init__(self, name: str, spec: StatisticSpec, *, ci: float = 0.683, bias_correction: bool = True):
        self.name = name
        self.spec = spec
        self.ci = ci
        self.bias_correction = bias_correction

    def __call__(self, x_s, rate_hz: float, tau_s):
        return compute(self.name, x_s, rate_hz, tau_s, ci=self.ci, bias_correction=self.bias_correction)

    def __repr__(self) -> str:
        return f"Statistic({self.name!r}, ci={self.ci}, bias_correction={self.bias_correction})"


def _build(config: StatisticConfig, context) -> Statistic:
    spec = context["spec"]
    return Statistic(spec.name, spec, **config.settings())


def statistic_entry(spec: StatisticSpec, summary: str = "") -> Entry:
    """The registry entry of ``spec`` (what a plugin's entry point names)."""
    if not isinstance(spec, StatisticSpec):
        raise TypeError(f"spec == {spec!r}, must be a StatisticSpec")
    return Entry(spec, StatisticConfig, summary, lambda config, context: _build(config, {"spec": spec}))


STATISTIC_REGISTRY = Registry("statistics", builtins=lambda: {name: statistic_entry(spec)
                                                              for name, spec in STATISTICS.items()})


def statistic_spec(name: str) -> StatisticSpec:
    """The :class:`StatisticSpec` called ``name``: the engine's table first, then the plugins."""
    if name in STATISTICS:
        return STATISTICS[name]
    try:
        entry = STATISTIC_REGISTRY.entry(name)
    except ValueError:
        raise ValueError(f"statistic == {name!r}, must be one of {sorted(STATISTIC_REGISTRY.names())}") from None
    if not isinstance(entry.target, StatisticSpec):
        raise TypeError(f"statistic {name!r}: its entry's target is {entry.target!r}, must be a StatisticSpec")
    return entry.target
