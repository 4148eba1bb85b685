"""The GPS channel reader (identification mode's input): 0.000 is missing, and Hatanaka files read too."""

from __future__ import annotations

import numpy as np

from chronofuse.io.rinex import read_gps_observations
from chronofuse.io.rinex_text import rinex_bytes


def test_zero_pseudoranges_are_missing_and_a_hatanaka_hour_reads_like_its_plain_copy(tmp_path, igs_stations):
    station = igs_stations["BOR1"]
    lines = rinex_bytes(station.obs_path).splitlines(keepends=True)
    epochs = [i for i, line in enumerate(lines) if line.startswith(b">")]
    plain = tmp_path / "bor1_10min.rnx"
    plain.write_bytes(b"".join(lines[:epochs[20]]))
    obs = read_gps_observations(plain)
    assert obs.gps_ns.size == 20 and obs.code == "C1C"
    assert not (obs.pseudorange_m == 0.0).any()
    for v in obs.other_codes_m.values():
        assert not (v == 0.0).any()
    # a 0.000 written into the text is read as missing, not as a 0 m pseudorange
    k = next(i for i in range(epochs[0] + 1, epochs[1]) if lines[i].startswith(b"G"))
    body = lines[k]
    zeroed = body[:3] + b"         0.000  " + body[19:]
    edited = tmp_path / "zeroed.rnx"
    edited.write_bytes(b"".join(lines[:k] + [zeroed] + lines[k + 1:epochs[20]]))
    again = read_gps_observations(edited)
    j = again.satellites.index(body[:3].decode())
    assert np.isnan(again.pseudorange_m[0, j]) and np.isfinite(obs.pseudorange_m[0, j])


def test_the_gps_reader_reads_a_hatanaka_file_as_its_plain_copy(tmp_path, igs_stations):
    import gzip

    import hatanaka

    lines = rinex_bytes(igs_stations["BOR1"].obs_path).splitlines(keepends=True)
    epochs = [i for i, line in enumerate(lines) if line.startswith(b">")]
    plain = tmp_path / "bor1.rnx"
    plain.write_bytes(b"".join(lines[:epochs[20]]))
    crx = tmp_path / "bor1.crx.gz"
    crx.write_bytes(gzip.compress(hatanaka.rnx2crx(plain.read_bytes())))
    a, b = read_gps_observations(plain), read_gps_observations(crx)
    assert b.source.endswith(".crx.gz") and b.gps_ns.size == 20
    np.testing.assert_array_equal(a.pseudorange_m, b.pseudorange_m)
