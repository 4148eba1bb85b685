"""The stated prior of a two-way link: what each Monte Carlo trial draws before its first exchange.

A trial draws its true clock offset ``eps_0 ~ N(offset_mean_s, offset_sigma_s^2)`` (B minus A at the
start), its skew (fractional frequency of B minus A) ``~ N(skew_mean, skew_sigma^2)``, its link's fixed
reply delay (URT, B's hardware) as the link model's ``urt_fixed_s`` plus ``N(0, urt_sigma_s^2)``, and its initial range uniformly in
``[max(0, d - range_spread_m), d + range_spread_m]`` around the scenario's ``d``. The filters start from
this prior and the bound (:mod:`chronofuse.sync.pcrb`) is the Bayesian bound of it: an estimator that
knows the prior cannot do better on average over trials drawn from it, the do-nothing estimator
included (its mean-square error is the prior's ``offset_sigma_s^2 + offset_mean_s^2``).

The URT drawn here is what the hardware does; the filters never see it, only the calibration's estimate
of it (:mod:`chronofuse.sync.calibration`), whose error the bound carries as one more state.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from chronofuse.seeding import child_rng, root_seed

__all__ = ["LinkPrior", "PriorDraw"]


_KEYS = {"offset": 0, "skew": 1, "urt": 2, "range": 3}


class PriorDraw(BaseModel):
    """One draw per trial: arrays of shape (trials,)."""

    model_config = ConfigDict(arbitrary_types_allowed=True, frozen=True)

    offset_s: np.ndarray
    skew: np.ndarray
    urt_deviation_s: np.ndarray
    range_m: np.ndarray


class LinkPrior(BaseModel):
    """The prior of one link's unknowns (module docstring); every field carries its unit in its name."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    offset_mean_s: float = Field(0.0, description="mean of the initial clock offset B - A (s)")
    offset_sigma_s: float = Field(1e-6, ge=0.0, description="sigma of the initial clock offset (s)")
    skew_mean: float = Field(0.0, ge=-1e-3, le=1e-3, description="mean fractional frequency offset B - A (fractional)")
    skew_sigma: float = Field(1e-8, ge=0.0, le=1e-4, description="sigma of the fractional frequency offset (fractional)")
    urt_sigma_s: float = Field(5e-9, ge=0.0, le=1e-6, description="sigma of the fixed reply delay across links (s)")
    range_spread_m: float = Field(0.0, ge=0.0, le=1e6, description="half-width of the initial range's spread (m)")

    def draw(self, distance_m: float, trials: int, seed) -> PriorDraw:
        """Trial ``i``'s draw comes from ``child_seed(seed, i, key)``: it does not depend on the trial count."""
        base = root_seed(seed)
        out = {name: np.empty(int(trials)) for name in _KEYS}
        lo = max(0.0, distance_m - self.range_spread_m)
        for i in range(int(trials)):
            out["offset"][i] = self.offset_mean_s + self.offset_sigma_s * child_rng(base, i, _KEYS["offset"]).standard_normal()
            out["skew"][i] = self.skew_mean + self.skew_sigma * child_rng(base, i, _KEYS["skew"]).standard_normal()
            out["urt"][i] = self.urt_sigma_s * child_rng(base, i, _KEYS["urt"]).standard_normal()
            out["range"][i] = child_rng(base, i, _KEYS["range"]).uniform(lo, distance_m + self.range_spread_m)
        return PriorDraw(offset_s=out["offset"], skew=out["skew"], urt_deviation_s=out["urt"], range_m=out["range"])
