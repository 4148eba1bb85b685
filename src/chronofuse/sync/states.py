"""A node's sync state, like a PTP port's, decided in one place for every filter.

``ACQUIRING`` (PTP's UNCALIBRATED): exchanges arrive but the uncertainty is not yet below ``lock_sigma_s``
for ``lock_hold_s``. ``LOCKED`` (SLAVE): it is, and the URT monitor has no alarm. ``HOLDOVER``: no usable
exchange for ``holdover_after`` exchanges in a row; the output is the filter's prediction and its
uncertainty grows with the clock model. A node cut off before it ever locked goes to HOLDOVER, never to
LOCKED. ``FAULT`` (FAULTY): the URT monitor flagged a changed reply delay; latched until a new calibration.
The promotion rules live here only (the linuxptp lesson: one place, not one per servo).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["ACQUIRING", "LOCKED", "HOLDOVER", "FAULT", "STATE_NAMES", "NodeStateConfig", "NodeStateMachine"]

ACQUIRING, LOCKED, HOLDOVER, FAULT = 0, 1, 2, 3
#: Code -> name, as reports print them.
STATE_NAMES = {ACQUIRING: "acquiring", LOCKED: "locked", HOLDOVER: "holdover", FAULT: "fault"}


class NodeStateConfig(BaseModel):
    """Thresholds of the state machine (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    lock_sigma_s: float = Field(1e-9, gt=0.0, description="uncertainty below which a node may lock (s)")
    lock_hold_s: float = Field(1.0, ge=0.0, description="how long it must stay below before LOCKED (s)")
    holdover_after: int = Field(3, ge=1, description="missed exchanges in a row that mean HOLDOVER (exchanges)")


class NodeStateMachine:
    """Pure core: ``init_state(trials)``, ``update(state, sigma_s, measured, alarm, interval_s)``."""

    def __init__(self, config: NodeStateConfig):
        self.config = config

    def init_state(self, trials: int) -> dict:
        return {"code": np.full(trials, ACQUIRING, dtype=np.int64), "below_s": np.zeros(trials),
                "missed": np.zeros(trials, dtype=np.int64)}

    def update(self, state: dict, sigma_s, measured, alarm, interval_s: float) -> dict:
        cfg = self.config
        missed = np.where(measured, 0, state["missed"] + 1)
        below = np.where(measured & (sigma_s <= cfg.lock_sigma_s), state["below_s"] + interval_s, 0.0)
        code = np.where(below >= cfg.lock_hold_s, LOCKED, ACQUIRING)
        code = np.where(missed >= cfg.holdover_after, HOLDOVER, code)
        code = np.where(np.asarray(alarm) | (state["code"] == FAULT), FAULT, code)
        return {"code": code.astype(np.int64), "below_s": below, "missed": missed}
