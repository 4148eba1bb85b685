"""The state machine: free-run -> acquiring -> locked -> holdover -> recovery, with reasons."""

import numpy as np
import pytest

from chronofuse.discipline.states import Reason, State, StateConfig, StateMachine, run_states

CFG = StateConfig(lock_threshold_s=100e-9, lock_hold_s=5.0)


def _scenario():
    usable = np.ones(40, bool)
    usable[:3] = False
    usable[20:25] = False
    offset = np.where(usable, 10e-9, np.nan)
    offset[3:6] = 1e-6  # acquiring, not settled yet
    return usable, offset


def test_the_states_follow_the_reference_and_the_lock_test():
    usable, offset = _scenario()
    run = run_states(usable[None], offset[None], CFG)
    s = run.state[0]
    assert (s[:3] == State.FREE_RUN).all()
    assert (s[3:10] == State.ACQUIRING).all()  # 3 unsettled seconds, then locked on the 5th settled one
    assert (s[10:20] == State.LOCKED).all()
    assert (s[20:25] == State.HOLDOVER).all()
    assert (s[25:29] == State.RECOVERY).all()
    assert (s[29:] == State.LOCKED).all()
    assert [c["reason"] for c in run.changes()] == ["reference_usable", "lock_achieved", "reference_lost",
                                                     "reference_usable", "lock_achieved"]


def test_an_integrity_alarm_puts_a_locked_gpsdo_in_holdover_and_says_why():
    usable = np.ones(30, bool)
    alarm = np.zeros(30, bool)
    alarm[15:] = True
    run = run_states(usable[None], np.full((1, 30), 1e-9), CFG, alarm=alarm[None])
    assert run.state[0, 14] == State.LOCKED and run.state[0, 15] == State.HOLDOVER
    assert run.reason[0, 15] == Reason.INTEGRITY_ALARM
    assert (run.state[0, 15:] == State.HOLDOVER).all()


def test_with_no_usable_receiver_at_all_it_stays_in_free_run():
    run = run_states(np.zeros((2, 50), bool), np.full((2, 50), np.nan), CFG)
    assert (run.state == State.FREE_RUN).all()
    assert run.seconds_in()["free_run"] == 50.0


def test_streaming_states_equal_the_batch_states():
    usable, offset = _scenario()
    batch = run_states(usable[None], offset[None], CFG)
    sm = StateMachine(CFG)
    stream = [sm.step(u, o) for u, o in zip(usable, offset)]
    assert [int(s) for s, _ in stream] == batch.state[0].tolist()
    assert [int(r) for _, r in stream] == batch.reason[0].tolist()


def test_a_lock_hold_shorter_than_one_sample_is_refused():
    with pytest.raises(ValueError, match="lock_hold_s"):
        StateConfig(lock_hold_s=0.5)


def test_the_compiled_state_machine_equals_its_numpy_twin():
    rng = np.random.default_rng(2)
    usable = rng.random((3, 3000)) > 0.02
    usable[:, 1000:1400] = False
    alarm = np.zeros_like(usable)
    alarm[1, 2000:2100] = True
    offset = np.where(usable, 150e-9 * rng.standard_normal((3, 3000)), np.nan)
    fast = run_states(usable, offset, CFG, alarm=alarm, fast=True)
    slow = run_states(usable, offset, CFG, alarm=alarm, fast=False)
    assert np.array_equal(fast.state, slow.state) and np.array_equal(fast.reason, slow.reason)
    assert len(set(fast.state.ravel().tolist())) == 5  # every state visited
