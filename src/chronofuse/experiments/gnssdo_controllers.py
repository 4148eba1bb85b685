"""The GNSSDO's controllers as a designer sets them up, and the free-running oscillator a run starts from.

Apart from :mod:`chronofuse.experiments.gnssdo` (which re-exports them) so that the design from data
(:mod:`chronofuse.experiments.gnssdo_design`), which the experiment calls, can build the same controllers
and oscillator without importing the experiment back.
"""

from __future__ import annotations

import numpy as np

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.design import design_measurement_sigma_s
from chronofuse.discipline.registry import SERVOS
from chronofuse.discipline.servo import Servo
from chronofuse.models.environment import ReceiverEnvironment
from chronofuse.models.oscillator import OscillatorModel, simulate_oscillator
from chronofuse.seeding import child_rng, child_seed
from chronofuse.validation import InputError, invalid

__all__ = ["DESIGN_STEER_S", "INITIAL_PHASE_MAX_S", "INITIAL_FREQUENCY_MAX", "INITIAL_FREQUENCY_FRACTION",
           "make_controller", "initial_frequency_max"]

#: The phase steering time constant the Kalman controllers are designed with (s): a trade between time
#: error (least with the steering as fast as the interval, the bound's unconstrained steering) and the
#: short-term stability (a fast steering writes the phase estimate's noise into the frequency). Measured
#: in open sky (default controller fitted on its calibration record, 3 trials of 12 h, seed 3), as TE
#: rms over the clairvoyant servo's and ADEV over the free-running oscillator's at 8 and 16 s:
#: 30 s 1.02, 2.2x, 2.7x; 100 s 1.05, 1.25x, 1.43x; 150 s 1.08, 1.15x, 1.26x; 200 s 1.10, 1.11x, 1.19x;
#: 300 s 1.13, 1.07x, 1.12x.
DESIGN_STEER_S = 200.0
#: Initial offsets of the free-running oscillator, uniform per trial: phase (s) and frequency (at most; see
#: :func:`initial_frequency_max`).
INITIAL_PHASE_MAX_S = 5e-4
INITIAL_FREQUENCY_MAX = 5e-9
#: The initial frequency offset is drawn within this fraction of what the EFC can pull once the run's aging is
#: set aside, so that the loop starts inside its tuning range with room to steer.
INITIAL_FREQUENCY_FRACTION = 0.5


def _check_controller(name: str) -> None:
    if name not in SERVOS:
        raise invalid("controller", name, f"one of {list(SERVOS.names())}")


def make_controller(name: str, osc: OscillatorModel, env: ReceiverEnvironment, receivers: int, dac: Dac | None,
                    loop_bandwidth_hz: float | None = None, measurement_sigma_s: float | None = None,
                    steer_s: float = DESIGN_STEER_S) -> Servo:
    """The controller ``name`` (any servo of :data:`~chronofuse.discipline.registry.SERVOS`) as a designer
    would set it up from data sheets (not from the truth).

    Every servo gets the DAC and the 1 s interval; the registry's context also offers the oscillator's
    h-coefficients and the receivers' short-term noise, which the Kalman types design with. ``pi``: the
    GNSSDO paper's preset (Kp 0.5, Ki 0.1), or designed from ``loop_bandwidth_hz`` (damping 1); a servo without a
    loop-bandwidth setting refuses ``loop_bandwidth_hz`` by name.
    """
    _check_controller(name)
    sigma = design_measurement_sigma_s(env, receivers) if measurement_sigma_s is None else measurement_sigma_s
    settings = {} if loop_bandwidth_hz is None else {"natural_hz": loop_bandwidth_hz}
    if "steer_s" in SERVOS.entry(name).config.model_fields:
        settings["steer_s"] = steer_s
    context = {"interval_s": 1.0, "dac": dac, "h": osc.h, "measurement_sigma_s": sigma}
    return SERVOS.create(name, context=context, **settings)


def initial_frequency_max(osc: OscillatorModel, duration_s: float) -> float:
    """Largest initial frequency offset drawn for ``osc`` over a run of ``duration_s``: at most
    :data:`INITIAL_FREQUENCY_MAX`, and :data:`INITIAL_FREQUENCY_FRACTION` of the EFC's pull (the smaller
    end of the DAC's range) less the aging over the run. An oscillator whose aging over the run alone
    outruns its EFC is refused (no loop could hold it)."""
    lo, hi = Dac.for_oscillator(osc).frequency_range
    room = min(-lo, hi) - abs(osc.drift_per_s) * duration_s
    if room <= 0:
        raise InputError(f"oscillator {osc.name!r}: its aging over {duration_s:g} s ({abs(osc.drift_per_s) * duration_s:.3g}) "
                         f"exceeds its EFC range ({min(-lo, hi):.3g}); no loop can hold it")
    return min(INITIAL_FREQUENCY_MAX, INITIAL_FREQUENCY_FRACTION * room)


def _free_phase(osc: OscillatorModel, steps: int, trials: int, root: np.random.SeedSequence,
                first_trial: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Free-running phase with each trial's initial offsets (the frequency one inside the EFC's range,
    :func:`initial_frequency_max`), and the same without them (for ADEV); trials ``first_trial`` on."""
    truth = simulate_oscillator(osc, float(steps), 1.0, child_seed(root, 0), trials=trials, first_trial=first_trial)
    t = truth.t_s
    offsets = np.array([child_rng(root, 2, first_trial + i).uniform(-1.0, 1.0, 2) for i in range(trials)])
    free = truth.x_s + offsets[:, :1] * INITIAL_PHASE_MAX_S + offsets[:, 1:] * initial_frequency_max(osc, steps) * t
    return free, truth.x_s
