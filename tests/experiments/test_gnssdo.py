

def test_reproduce_gnssdo_keeps_the_published_streams_at_seed_0_and_shares_none_across_seeds():
    from chronofuse.experiments.gnssdo_reproduce import _stream

    parts = (1, 2, 3, 4, 11, 12, 21, 22)
    assert [_stream(0, k) for k in parts] == list(parts)
    streams = [_stream(seed, k) for seed in range(50) for k in parts]
    assert len(set(streams)) == len(streams)
