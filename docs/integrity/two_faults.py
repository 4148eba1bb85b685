"""Regenerates the two-fault table of docs/integrity/raim.md (4000 simulated epochs per row, about a minute):
``python docs/integrity/two_faults.py`` from the repository root. It uses the simulated sky of the RAIM tests."""
import sys

sys.path[:0] = ["tests", "tests/integrity"]
import numpy as np
from test_raim import sky, measure, misleading, _OPEN
from chronofuse.integrity.raim import RaimSettings, raim
from chronofuse.analysis.metrics import clopper_pearson
for n_sat in (9, 12):
  for mult in (1.0, 3.0):
    rng = np.random.default_rng(40 + n_sat)
    epochs, budget = 4000, 1e-2
    site, sat = sky(rng, epochs, n_sat)
    sigma = np.full((epochs, n_sat), 3.0)
    cfg = RaimSettings(pfa=1e-2, integrity_risk=budget, **_OPEN)
    sysm = np.zeros(n_sat, int)
    clean = raim(sat, measure(rng, site, sat, sigma), sigma, sysm, site + 300.0, cfg)
    bias = np.zeros((epochs, n_sat))
    for e in range(epochs):
        two = rng.choice(n_sat, 2, replace=False)
        m = clean.mdb_m[e, two]
        bias[e, two] = rng.uniform(0, mult, 2) * np.where(np.isfinite(m), m, 100.0) * rng.choice([-1, 1], 2)
    res = raim(sat, measure(rng, site, sat, sigma, bias), sigma, sysm, site + 300.0, cfg)
    k = int(misleading(site, res).sum()); lo, hi = clopper_pearson(k, epochs, level=0.95)
    print(f"{n_sat} sats, two faults 0..{mult:g}x MDB: misleading {k}/{epochs} = {k/epochs:.4f} (95% CI {lo:.4f}..{hi:.4f}), budget {budget}; states", {s: int((res.state == s).sum()) for s in ("ok","excluded","alarm","unavailable")})
