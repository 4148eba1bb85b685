"""Stages of a long job share its 0..1 by their expected costs (:func:`chronofuse.progress.stages`), so the
ETA drawn from the fractions follows the work left."""

import pytest

from chronofuse.progress import stages, within


def _recorder():
    heard = []
    return heard, lambda message, fraction=None: heard.append((message, fraction))


def test_stages_span_the_job_by_their_weights_and_map_each_stage_onto_its_own_span():
    heard, say = _recorder()
    a, b, c = stages(say, [1, 3, 0])
    a("one")
    a("one, half", 0.5)
    b("two")
    b("two, half", 0.5)
    b("two, no fraction")  # at the last fraction the stage gave
    c("three")
    assert heard == [("one", 0.0), ("one, half", 0.125), ("two", 0.25), ("two, half", 0.625),
                     ("two, no fraction", 0.625), ("three", 1.0)]


def test_a_fraction_outside_0_1_is_clipped_to_its_stage():
    heard, say = _recorder()
    inner = within(say, 0.2, 0.6)
    inner("over", 1.5)
    inner("under", -1.0)
    assert heard == [("over", pytest.approx(0.6)), ("under", pytest.approx(0.2))]


@pytest.mark.parametrize("weights", [[], [0, 0], [1, -1]])
def test_weights_without_a_positive_sum_or_with_a_negative_one_are_refused(weights):
    with pytest.raises(ValueError, match="weights =="):
        stages(lambda message, fraction=None: None, weights)
