"""Grid slots: samples placed by their offset from the first, jitter tolerated, bad steps located."""

import numpy as np

from chronofuse.io.grid import grid_slots, place_on_grid


def test_slots_follow_the_offsets_and_missing_slots_become_nan():
    slots, bad = grid_slots(np.array([0.0, 1.0, 2.0, 5.0]), 1.0, 1e-6)
    assert bad == -1 and slots.tolist() == [0, 1, 2, 5]
    grid = place_on_grid(slots, np.array([1.0, 2.0, 3.0, 6.0]))
    np.testing.assert_array_equal(np.isnan(grid), [False, False, False, True, True, False])


def test_jitter_within_the_tolerance_does_not_accumulate_over_a_long_record():
    t = np.arange(100_000) + np.where(np.arange(100_000) % 2, 0.001, -0.001)  # 999/1001 ms steps
    slots, bad = grid_slots(t - t[0], 1.0, 0.05)
    assert bad == -1 and slots[-1] == 99_999


def test_the_first_sample_off_its_slot_or_not_advancing_is_reported():
    assert grid_slots(np.array([0.0, 1.0, 2.5, 3.0]), 1.0, 1e-6)[1] == 2
    assert grid_slots(np.array([0.0, 1.0, 1.0004, 3.0]), 1.0, 1e-3)[1] == 2
