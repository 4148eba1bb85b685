"""Oscillator truth model: simulating OCXO phase, ours vs allantools' Kasdin–Walter generator.

Rows:
- ``ocxo_phase``: ``simulate_oscillator(preset("ocxo"), n, 1 Hz)`` (all five power-law terms plus
  drift) against allantools generating the same five noise types as phase with ``allantools.Noise``
  (Kasdin & Walter 1992, one 2n-point FFT convolution per type) and summing them. Target ratio >= 1.
- ``flicker_generator``: one K-W flicker series, ``power_law_noise(-1, n)`` vs ``allantools.Noise(b=-1)``.
- ``ocxo_peak_memory``: peak resident memory (``VmHWM``, interpreter and imports included) of
  ``simulate_oscillator(preset("ocxo"), n, 1 Hz)`` in a fresh subprocess. Target < 1 GiB at n = 1e7.

n = 1e7 (quick: 1e6). Run alone: ``.venv/bin/python benchmarks/bench_oscillator.py [--quick]``.
"""

from __future__ import annotations

import subprocess
import sys
import time

import allantools
import numpy as np

from chronofuse.models.noise import power_law_noise
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset

from _timing import best_of

# allantools' phase-PSD exponent b for each S_y coefficient (b = a - 2).
_PHASE_EXPONENT = {"h2": 0, "h1": -1, "h0": -2, "hm1": -3, "hm2": -4}

_MEMORY_SCRIPT = """
import resource, sys
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
truth = simulate_oscillator(preset("ocxo"), float(sys.argv[1]), 1.0, seed=1)
assert truth.x_s.shape == (1, int(sys.argv[1]))
try:  # VmHWM belongs to this process image; ru_maxrss also carries the forking parent's peak
    with open("/proc/self/status") as status:
        print(next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024.0)
except OSError:
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
"""


def _allantools_ocxo_phase(n: int) -> np.ndarray:
    """The OCXO's five power-law terms as phase, each by allantools' K-W generator, summed."""
    model = preset("ocxo")
    tau0_s = 1.0
    total = np.zeros(n)
    for key, h_value in model.h.as_dict().items():
        if h_value <= 0.0:
            continue
        noise = allantools.Noise(nr=n, qd=1.0, b=_PHASE_EXPONENT[key])
        qd = h_value / noise.frequency_psd_from_qd(tau0_s)  # psd is linear in qd
        noise.set_input(nr=n, qd=qd, b=_PHASE_EXPONENT[key])
        noise.generateNoise()
        total += noise.time_series
    return total


def peak_memory_mib(n: int) -> float:
    """Peak RSS (MiB) of simulating ``n`` OCXO steps in a fresh Python process."""
    result = subprocess.run(
        [sys.executable, "-c", _MEMORY_SCRIPT, str(n)], capture_output=True, text=True, check=True
    )
    return float(result.stdout.strip().splitlines()[-1])


def run(quick: bool = False) -> list[dict]:
    n = 10**6 if quick else 10**7
    repeat = 2 if quick else 1
    np.random.seed(0)  # allantools draws from numpy's global generator

    ours_s = best_of(lambda: simulate_oscillator(preset("ocxo"), float(n), 1.0, seed=1), repeat)
    base_s = best_of(lambda: _allantools_ocxo_phase(n), repeat)
    rows = [
        {
            "name": f"ocxo_phase_{n:.0e}",
            "ours_s": ours_s,
            "baseline": "allantools.Noise (Kasdin), 5 noise types summed",
            "baseline_s": base_s,
            "ratio": base_s / ours_s,
            "target": ">= 1",
            "passed": base_s / ours_s >= 1.0,
            "note": "ours also adds drift and the exact RW-FM/flicker shaping; same n phase samples",
        }
    ]

    ours_s = best_of(lambda: power_law_noise(-1.0, n, np.random.default_rng(1)), repeat)

    def baseline_flicker():
        allantools.Noise(nr=n, qd=1.0, b=-1).generateNoise()

    base_s = best_of(baseline_flicker, repeat)
    rows.append(
        {
            "name": f"flicker_generator_{n:.0e}",
            "ours_s": ours_s,
            "baseline": "allantools.Noise(b=-1).generateNoise",
            "baseline_s": base_s,
            "ratio": base_s / ours_s,
            "target": ">= 1",
            "passed": base_s / ours_s >= 1.0,
            "note": "one K-W flicker series; ours by partitioned FFT convolution",
        }
    )

    start = time.perf_counter()
    peak_mib = peak_memory_mib(n)
    rows.append(
        {
            "name": f"ocxo_peak_memory_{n:.0e}",
            "ours_s": time.perf_counter() - start,
            "baseline": "",
            "baseline_s": None,
            "ratio": None,
            "target": "< 1024 MiB",
            "passed": peak_mib < 1024.0,
            "note": f"peak RSS {peak_mib:.0f} MiB in a fresh subprocess (VmHWM, imports included)",
        }
    )
    return rows


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv[1:]):
        print(row)
