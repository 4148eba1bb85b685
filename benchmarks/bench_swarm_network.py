"""A 200-node swarm for 600 s on Dask (a LocalCluster of 2 worker processes) against the same run serial in
this process: wall time, peak memory, and whether the two give identical numbers.

The link work (718 links: calibration, exchanges, ``doppler-kf``) is cut into tasks of 100 links; the node
times are composed here. Baseline: the serial run (ratio = serial / Dask, > 1 when the cluster pays off; on a
2-core machine the cluster's start, about 5-10 s, is in it). Memory: this process's peak resident size over
the serial run (``ru_maxrss``) and the workers' peaks as they report them. ``quick``: 40 nodes, 120 s.
Run alone: ``.venv/bin/python benchmarks/bench_swarm_network.py [--quick]``.
"""

from __future__ import annotations

import resource
import sys
import time

import numpy as np

from chronofuse.experiments.swarm_network import SwarmScenario, run_swarm


def _scenario(quick: bool) -> SwarmScenario:
    if quick:
        return SwarmScenario(nodes=40, duration_s=120.0, area_m=200e3, radio_range_m=120e3, mean_up_s=300.0)
    return SwarmScenario(nodes=200, duration_s=600.0, area_m=400e3, radio_range_m=120e3, mean_up_s=300.0)


def _worker_peak_mib(client) -> float:
    peaks = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return max(peaks.values()) / 1024.0


def run(quick: bool = False) -> list[dict]:
    from distributed import Client, LocalCluster

    sc = _scenario(quick)
    start = time.perf_counter()
    serial = run_swarm(sc, 1, scheduler="serial", chunk_links=100)
    serial_s = time.perf_counter() - start
    driver_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    start = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        dask = run_swarm(sc, 1, scheduler=cluster.scheduler_address, chunk_links=100)
        workers_mib = _worker_peak_mib(client)
    dask_s = time.perf_counter() - start
    same = all(np.array_equal(getattr(serial.time, f), getattr(dask.time, f), equal_nan=True)
               for f in ("correction_s", "sigma_s", "state", "parent"))
    return [{"name": f"{sc.nodes}-node swarm, {sc.duration_s:g} s, {serial.links.shape[0]} links, Dask (2 workers)",
             "ours_s": dask_s, "baseline": "the same run serial in this process", "baseline_s": serial_s,
             "ratio": serial_s / dask_s, "target": "identical numbers", "passed": bool(same),
             "note": f"serial {serial_s:.1f} s, Dask {dask_s:.1f} s (cluster start included); peak memory "
                     f"{driver_mib:.0f} MiB in this process, {workers_mib:.0f} MiB per worker at most; "
                     f"identical: {same}"}]


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print(row)
