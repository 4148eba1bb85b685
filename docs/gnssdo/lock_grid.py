"""LOCKED fraction and lies (LOCKED with |TE| over the threshold) across every scenario and preset, 1 and 3 receivers
(4 trials of 14,400 s, seed 11, designed from the data sheet):  python docs/gnssdo/lock_grid.py [ocxo,tcxo,rb,csac]"""
import sys, time
import numpy as np
from chronofuse.experiments.gnssdo import GnssdoSetup, SCENARIOS, simulate_gnssdo, evaluate
t0 = time.time()
oscs = sys.argv[1].split(",") if len(sys.argv) > 1 else ["ocxo", "tcxo", "rb", "csac"]
for osc in oscs:
    for sc in SCENARIOS:
        for R in (1, 3):
            s = evaluate(simulate_gnssdo(GnssdoSetup(scenario=sc, oscillator=osc, receivers=R, duration_s=14400,
                                                     trials=4, seed=11, design="datasheet")))
            st = s["state_seconds"]
            tot = sum(st.values())
            print(f"{osc:5s} {sc:14s} R={R} LOCKED {st['locked']/tot:.4f} alarm {st['alarm']/tot:.4f} "
                  f"lies {s['locked_over_threshold_seconds']}", flush=True)
print(f"{time.time()-t0:.0f} s")
