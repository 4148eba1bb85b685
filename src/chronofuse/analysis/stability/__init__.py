"""Clock stability statistics: one engine, named wrappers, one result type.

Every statistic takes PHASE in seconds (convert frequency data with :func:`frequency_to_phase`) and has
the same signature, ``stat(x_s, rate_hz, tau_s, *, ci=0.683, bias_correction=True)``, returning
a :class:`Deviation` with the deviation, Stable32's noise type ``alpha``, the EDF and the confidence
interval at each averaging time. ``tau_s`` is an array of seconds: ``tau_grid("octave", N, rate_hz, name)``
builds the standard grids. ``compute(name, ...)`` is the same by name; ``STATISTICS`` lists them.
"""

from __future__ import annotations

from chronofuse.analysis.stability.convert import frequency_to_phase, phase_to_frequency
from chronofuse.analysis.stability.engine import STATISTICS, compute
from chronofuse.analysis.stability.result import Deviation
from chronofuse.analysis.stability.taus import averaging_factors, tau_grid

__all__ = [
    "adev",
    "oadev",
    "mdev",
    "tdev",
    "hdev",
    "ohdev",
    "totdev",
    "mtotdev",
    "htotdev",
    "ttotdev",
    "theo1",
    "theobr",
    "theoh",
    "tie_rms",
    "mtie",
    "compute",
    "STATISTICS",
    "Deviation",
    "frequency_to_phase",
    "phase_to_frequency",
    "averaging_factors",
    "tau_grid",
]

_DESCRIPTIONS = {
    "adev": "Allan deviation (non-overlapping), NIST SP 1065 eq. (7)",
    "oadev": "overlapping Allan deviation, NIST SP 1065 eq. (11)",
    "mdev": "modified Allan deviation, NIST SP 1065 eq. (14)",
    "tdev": "time deviation tau/sqrt(3) MDEV in seconds, NIST SP 1065 eq. (15)",
    "hdev": "Hadamard deviation (non-overlapping), NIST SP 1065 eq. (17)",
    "ohdev": "overlapping Hadamard deviation, NIST SP 1065 eq. (18)",
    "totdev": "total deviation, NIST SP 1065 eq. (25), bias-corrected as Stable32",
    "mtotdev": "modified total deviation, NIST SP 1065 eqs. (27)-(28)",
    "ttotdev": "time total deviation tau/sqrt(3) MTOTDEV in seconds, NIST SP 1065 eq. (29)",
    "htotdev": "Hadamard total deviation, NIST SP 1065 eqs. (30)-(31), bias-corrected as Stable32",
    "theo1": "Theo1 deviation at tau = 0.75 m tau0 (m even), NIST SP 1065 (Theo1)",
    "theobr": "bias-removed Theo1 at tau = 0.75 m tau0 (m even), NIST SP 1065 (TheoBR); Howe, Metrologia 2006",
    "theoh": "hybrid: overlapping ADEV below 10 % of the record, TheoBR above, NIST SP 1065 (TheoH)",
    "tie_rms": "rms time interval error in seconds, ITU-T G.810",
    "mtie": "maximum time interval error in seconds, ITU-T G.810 (no confidence interval)",
}


def _wrapper(name: str):
    """The public function for one statistic: ``compute(name, ...)`` with its own name and docstring."""

    def statistic(x_s, rate_hz: float, tau_s, *, ci: float = 0.683, bias_correction: bool = True,
                  gap_rule: str | None = None) -> Deviation:
        return compute(name, x_s, rate_hz, tau_s, ci=ci, bias_correction=bias_correction, gap_rule=gap_rule)

    statistic.__name__ = statistic.__qualname__ = name
    statistic.__doc__ = (
        f"{_DESCRIPTIONS[name][0].upper()}{_DESCRIPTIONS[name][1:]}.\n\n"
        "Parameters: ``x_s`` phase in seconds, shape (N,), NaN for missing samples; ``rate_hz`` sample\n"
        "rate (> 0); ``tau_s`` averaging times in seconds, shape (k,) (``tau_grid`` builds octave/decade\n"
        "grids); ``ci`` confidence of the interval; ``bias_correction`` as Stable32; ``gap_rule`` which\n"
        "terms a missing sample removes (see :func:`compute`).\n"
        "Returns a :class:`Deviation` of shape (k,) (see :func:`compute`)."
    )
    return statistic


adev = _wrapper("adev")
oadev = _wrapper("oadev")
mdev = _wrapper("mdev")
tdev = _wrapper("tdev")
hdev = _wrapper("hdev")
ohdev = _wrapper("ohdev")
totdev = _wrapper("totdev")
mtotdev = _wrapper("mtotdev")
htotdev = _wrapper("htotdev")
ttotdev = _wrapper("ttotdev")
theo1 = _wrapper("theo1")
theobr = _wrapper("theobr")
theoh = _wrapper("theoh")
tie_rms = _wrapper("tie_rms")
mtie = _wrapper("mtie")
