"""Small link runs shared by the sync tests."""

import numpy as np

from chronofuse.models.kinematics import radial_geometry
from chronofuse.models.link import LinkModel, simulate_exchanges

NOISELESS = LinkModel(toa_model="none", urt_fixed_s=0.0, urt_jitter_s=0.0)


def exchanges(distance_m=80e3, velocity_m_s=0.0, *, link=NOISELESS, steps=200, trials=2, offset_s=0.0, skew=0.0, seed=0):
    a, b = radial_geometry(distance_m, velocity_m_s)
    t = np.arange(steps + 2) * link.interval_s
    x_a = np.zeros((trials, steps + 2))
    x_b = np.broadcast_to(offset_s + skew * t, (trials, steps + 2)).copy()
    return simulate_exchanges(a, b, x_a, x_b, link, steps, seed)
