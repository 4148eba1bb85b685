"""Coherent steps of every receiver, straight or after a gap, and pulse trains: seconds reported LOCKED with the
output's |TE| at or above 100 ns (lies), over 6 seeds (OCXO, 3 receivers, 12,000 s, onset at 7200 s).

    python docs/gnssdo/coherent_steps.py [open-sky|urban-canyon]
"""
import sys

import numpy as np

from chronofuse.discipline.chain import ChainConfig, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.states import State
from chronofuse.experiments.gnssdo import _free_phase, make_controller, plausibility_monitors, state_config
from chronofuse.models.environment import receiver_environment
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import root_seed

ONSET = 7200


def lies(pert, env_name, seed, gap=None, receivers=3, steps=12_000):
    osc, env = preset("ocxo"), receiver_environment(env_name)
    free, _ = _free_phase(osc, steps, 1, root_seed(seed))
    rx = simulate_receivers(env, steps, receivers, seed + 1, trials=1)
    pps = rx.pps_error_s + pert(np.arange(steps))
    if gap is not None:
        pps[..., gap[0]:gap[1]] = np.nan
    monitors = plausibility_monitors(osc, env, receivers)
    config = ChainConfig(states=state_config(osc), receiver_monitor=monitors[0], reference_monitor=monitors[1])
    servo = make_controller("gated-kalman", osc, env, receivers, Dac.for_oscillator(osc))
    run = discipline_run(servo, free, pps, rx.epochs, config)
    return int(((run.states.state[0] == State.LOCKED) & (np.abs(run.phase_s[0]) >= 100e-9)).sum())


def step(a):
    return lambda t: np.where(t >= ONSET, a, 0.0)


def train(a, period, on):
    return lambda t: np.where((t >= ONSET) & (t % period < on), a, 0.0)


CASES = {"clean": (lambda t: 0.0 * t, None), "step 105 ns": (step(105e-9), None), "step 150 ns": (step(150e-9), None),
         "step 300 ns": (step(300e-9), None), "train 130 ns 3 s in 4": (train(130e-9, 4, 3), None),
         "train 140 ns 2 s in 3": (train(140e-9, 3, 2), None),
         "gap 40 s, then 150 ns": (step(150e-9), (ONSET - 40, ONSET)),
         "gap 200 s, then 150 ns": (step(150e-9), (ONSET - 200, ONSET))}

if __name__ == "__main__":
    env_name = sys.argv[1] if len(sys.argv) > 1 else "open-sky"
    for name, (pert, gap) in CASES.items():
        print(f"{name:24s} {sum(lies(pert, env_name, seed, gap) for seed in range(3, 9)):6d} lie seconds", flush=True)
