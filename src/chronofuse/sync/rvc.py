"""RTT-RVC: relative-velocity-compensated two-way offset per exchange (the swarm paper's eq. 9, its ref. [28]).

Each exchange's offset is the paper's eq. (9) with the Doppler radial velocity ``v``; ``light_time="exact"``
uses :func:`~chronofuse.sync.twoway.rvc_offset_exact_s` instead (the uplink's ``S1 v / c^2`` term kept;
ours, not the paper's). No URT compensation and no smoothing: the fixed URT ``t_p`` biases the result
by ``alpha t_p`` (the paper's eq. 17).
"""

from __future__ import annotations

from chronofuse.sync.base import SyncAlgorithm
from chronofuse.sync.twoway import rvc_offset_exact_s, rvc_offset_paper_s
from chronofuse.validation import check_choice

__all__ = ["RttRvc", "rvc_offset"]


def rvc_offset(sample, light_time: str):
    """The velocity-compensated offset of one exchange (trials,)."""
    f = rvc_offset_paper_s if light_time == "paper" else rvc_offset_exact_s
    return f(sample.t_i_s, sample.t_b_s, sample.t_r_s, sample.velocity_m_s)


class RttRvc(SyncAlgorithm):
    """The paper's eq. (9) per exchange (``light_time="paper"``) or its exact-light-time form (``"exact"``)."""

    name = "rtt-rvc"

    def __init__(self, light_time: str = "paper", interval_s: float = 0.01):
        self.light_time = light_time
        self.interval_s = interval_s

    def _check_params(self):
        check_choice(self.light_time, "light_time", ("paper", "exact"))

    def init_state(self, trials):
        return {}

    def update(self, state, sample):
        return state, rvc_offset(sample, self.light_time)
