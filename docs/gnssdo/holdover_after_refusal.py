"""After a coherent drag is refused, does holdover keep the spoofer's frequency? TE 1 h into holdover against
an outage at the moment of refusal (the same oscillator and receivers, the drag removed)."""
import dataclasses
import numpy as np
from chronofuse.discipline.chain import ChainConfig, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.states import Reason, State
from chronofuse.experiments.gnssdo import _free_phase, make_controller, plausibility_monitors, state_config
from chronofuse.models.environment import receiver_environment
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import root_seed
ON = 7200
osc = preset("ocxo"); env = receiver_environment("open-sky")
steps = ON + 3 * 3600
for rate in (0.1e-9, 0.3e-9, 2e-9, 20e-9):
    out = []
    for seed in range(3, 9):
        free, _ = _free_phase(osc, steps, 1, root_seed(seed))
        rx = simulate_receivers(env, steps, 3, seed + 1, trials=1)
        t = np.arange(steps)
        monitors = plausibility_monitors(osc, env, 3)
        config = ChainConfig(states=state_config(osc), receiver_monitor=monitors[0], reference_monitor=monitors[1])
        def go(pps):
            servo = make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc))
            return discipline_run(servo, free, pps, rx.epochs, config)
        r = go(rx.pps_error_s + np.where(t >= ON, rate * (t - ON), 0.0))
        ref = np.flatnonzero(r.states.reason[0, ON:] == Reason.IMPLAUSIBLE_REFERENCE)
        k0 = ON + ref[0]
        # the same seconds as a plain outage from the refusal on (no drag): holdover from a clean loop
        pps = rx.pps_error_s.copy(); pps[..., k0:] = np.nan
        c = go(pps)
        h = k0 + 3600
        out.append((ref[0], r.phase_s[0, k0] * 1e9, r.phase_s[0, h] * 1e9, c.phase_s[0, h] * 1e9))
    a = np.array(out)
    print(f"drag {rate*1e9:.1f} ns/s: refused after {a[:,0].mean():.0f} s, |TE| at refusal {np.abs(a[:,1]).mean():.1f} ns, "
          f"1 h later rms {np.sqrt((a[:,2]**2).mean()):.1f} ns vs clean holdover {np.sqrt((a[:,3]**2).mean()):.1f} ns", flush=True)
