"""Fixtures shared by the stability tests: the real records and NIST SP 1065's 1000-point set."""

import numpy as np
import pytest

from chronofuse.analysis.stability.convert import frequency_to_phase


@pytest.fixture(scope="session")
def nbs14_phase() -> np.ndarray:
    """NIST SP 1065's 1000-point test set (section 12.1, p. 107): the portable generator
    n_{i+1} = 16807 n_i mod 2147483647, n_0 = 1234567890, scaled to [0, 1] as fractional frequency,
    integrated to 1001 phase points at tau0 = 1 s."""
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # the values SP 1065 prints
    return frequency_to_phase(np.array(n) / 2147483647.0, 1.0)


@pytest.fixture(scope="session")
def phase_dat(data_dir) -> np.ndarray:
    """Stable32's PHASE.DAT (1001 phase points, 1 Hz)."""
    return np.loadtxt(data_dir / "stability" / "phasedat" / "PHASE.DAT")


@pytest.fixture(scope="session")
def records(data_dir, phase_dat):
    """Phase records (seconds, 1 Hz) of the four data sets, as Stable32 analysed them."""
    stab = data_dir / "stability"
    f_hz = np.loadtxt(stab / "ocxo" / "ocxo_frequency.txt")
    # Stable32's header says the average is 1.0: it analysed f / mean(f); the fractional frequency
    # (f - mean f) / mean f differs from it by a constant, which no statistic sees.
    y = (f_hz - f_hz.mean()) / f_hz.mean()
    return {
        "phasedat": phase_dat,
        "ocxo": frequency_to_phase(y, 1.0),
        "gps": np.loadtxt(stab / "gps" / "gps_1pps_phase_data.txt.gz"),
        "Cs5071A": np.loadtxt(stab / "Cs5071A" / "5071A_phase.txt.gz"),
    }
