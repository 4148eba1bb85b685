"""A swarm over two-way links (orchestration only): nodes, their clocks and paths, one filter per link, the
leader elected on clock quality, and each node's time composed by :mod:`chronofuse.sync.swarm`.

Truth: ``nodes`` aircraft flying a formation (a common velocity plus each its own small velocity) over an
area; each a free-running oscillator since GNSS was jammed (its time and frequency at that instant off by
``initial_time_sigma_s`` and ``initial_frequency_sigma``), node 0 the best oscillator. Links join nearest
neighbours within radio range (:func:`~chronofuse.sync.swarm.graph.neighbour_links`); each link is calibrated
(:func:`~chronofuse.experiments.swarm.calibrate_scenario`'s procedure, before the jamming), then exchanges
every ``interval_s`` while it is up (its own two-state availability chain, independent of every other link,
within range, both nodes there); its ``doppler-kf`` predicts through its gaps. The leader elected at
``leader_loss_at_s`` can leave the swarm then, and a node can be cut off (``cut_off``).

Every link's work is one task (its seeds: ``child_seed(root, LINK, index)``), so the links run in chunks on
Dask (``scheduler``) or here, with identical numbers; composing the node times is cheap and runs here.

:func:`follow_leader` (the main job's call) is a leader clock series and a star of followers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from chronofuse.estimation.interface import FrozenResult
from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.kinematics import constant_velocity
from chronofuse.models.link import LinkModel, node_clock_error_s, simulate_exchanges
from chronofuse.models.oscillator_presets import preset
from chronofuse.seeding import child_rng, child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.calibration import CalibrationConfig, calibrate_urt
from chronofuse.sync.prior import LinkPrior
from chronofuse.sync.registry import LinkKnowledge, make_algorithm
from chronofuse.sync.states import FAULT
from chronofuse.sync.swarm.election import (CLASS_GNSS, CLASS_HOLDOVER, OSCILLATOR_QUALITY, ClockQuality, heard,
                                            leader_timeline)
from chronofuse.sync.swarm.graph import in_range, neighbour_links
from chronofuse.sync.swarm.timekeeping import SwarmTime, compose_network_time
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = ["SwarmScenario", "SwarmRun", "swarm_truth", "link_tasks", "run_link_task", "run_swarm", "leader_clock_s",
           "link_availability", "follow_leader", "SwarmResult"]

_NODE, _LINK, _AVAIL, _PLACE = 0, 1, 2, 3


@dataclass(frozen=True)
class SwarmScenario:
    """A swarm (module docstring); times in s, distances in m."""

    nodes: int = 4
    duration_s: float = 600.0
    interval_s: float = 1.0
    area_m: float = 60e3
    speed_m_s: float = 200.0
    relative_speed_m_s: float = 5.0
    radio_range_m: float = 150e3
    neighbours: int = 6
    leader_oscillator: str = "rb"
    oscillator: str = "ocxo"
    initial_time_sigma_s: float = 5e-9
    initial_frequency_sigma: float = 1e-11
    leader_loss_at_s: float | None = None
    mean_up_s: float = math.inf
    mean_down_s: float = 30.0
    cut_off: tuple = ()
    topology: str = "tree"
    leader_weight: float = 0.5
    snr_db: float = 10.0
    prior: LinkPrior = LinkPrior(skew_sigma=1e-9)
    calibration: CalibrationConfig = CalibrationConfig()

    def __post_init__(self):
        check_scalar(self.nodes, "nodes", min_val=2, max_val=5000, integer=True)
        check_scalar(self.interval_s, "interval_s", min_val=1e-3, max_val=60.0)
        check_scalar(self.duration_s, "duration_s", min_val=3 * self.interval_s)
        check_scalar(self.area_m, "area_m", min_val=0.0, include_min=False)  # 0: every node at one point
        check_scalar(self.radio_range_m, "radio_range_m", min_val=0.0, include_min=False)
        check_scalar(self.neighbours, "neighbours", min_val=1, integer=True)
        check_choice(self.topology, "topology", ("tree", "consensus"))
        # a mean time is checked whether or not it is used (an infinite mean-up leaves mean-down unused)
        if not (isinstance(self.mean_up_s, (int, float)) and self.mean_up_s == math.inf):
            check_scalar(self.mean_up_s, "mean_up_s", min_val=0.0, include_min=False)
        check_scalar(self.mean_down_s, "mean_down_s", min_val=0.0, include_min=False)
        preset(self.oscillator)
        try:
            preset(self.leader_oscillator)
        except InputError as exc:
            raise InputError(exc.message.replace("{oscillator}", "{leader_oscillator}"),
                             fields=("leader_oscillator",)) from None
        if self.leader_loss_at_s is not None:
            check_scalar(self.leader_loss_at_s, "leader_loss_at_s", min_val=0.0, max_val=self.duration_s)
        for item in self.cut_off:
            text = ":".join(f"{v:g}" if isinstance(v, float) else str(v) for v in item)
            if len(item) != 3 or not 0 <= int(item[0]) < self.nodes:
                raise InputError(f"{{cut_off}} == {text}, must be NODE:FROM:TO with NODE an existing node "
                                 f"(0 to {self.nodes - 1} of {{nodes}})", fields=("cut_off", "nodes"))
            if not 0.0 <= float(item[1]) < float(item[2]):
                raise InputError(f"{{cut_off}} == {text}, must be NODE:FROM:TO with 0 <= FROM < TO (s)",
                                 fields=("cut_off",))

    @property
    def steps(self) -> int:
        return int(round(self.duration_s / self.interval_s))

    @property
    def link(self) -> LinkModel:
        return LinkModel(interval_s=self.interval_s, snr_db=self.snr_db)

    def oscillator_of(self, node: int) -> str:
        return self.leader_oscillator if node == 0 else self.oscillator


@dataclass(frozen=True)
class SwarmRun(FrozenResult):
    """A swarm run: the composed :class:`SwarmTime` (``time``), the truth (``clocks_s`` (n, steps) each node's
    clock error to true time), the links (L, 2) and when each was usable (L, steps), who was alive."""

    time: SwarmTime
    clocks_s: np.ndarray
    links: np.ndarray
    usable: np.ndarray
    alive: np.ndarray

    @property
    def to_true_s(self) -> np.ndarray:
        """Each node's corrected time error to true time (n, steps)."""
        return self.clocks_s - self.time.correction_s

    def to_leader_s(self) -> np.ndarray:
        """Each node's corrected time to the current leader's (n, steps); NaN while there is no leader."""
        lead = self.time.leader
        ok = lead >= 0
        ref = np.full(lead.shape, np.nan)
        cols = np.flatnonzero(ok)
        ref[cols] = self.to_true_s[lead[cols], cols]
        return self.to_true_s - ref[None, :]


def swarm_truth(sc: SwarmScenario, seed) -> dict:
    """Node positions and velocities (n, 3), the links, and each node's clock error (n, steps + 2)."""
    base = root_seed(seed)
    rng = child_rng(base, _PLACE)
    n, steps, dt = sc.nodes, sc.steps, sc.interval_s
    pos = np.column_stack([rng.uniform(0.0, sc.area_m, n), rng.uniform(0.0, sc.area_m, n), rng.uniform(2e3, 6e3, n)])
    heading = rng.uniform(0.0, 2 * np.pi, n)
    vel = np.column_stack([sc.speed_m_s + sc.relative_speed_m_s * np.cos(heading),
                           sc.relative_speed_m_s * np.sin(heading), np.zeros(n)])
    t = np.arange(steps + 2) * dt
    # every follower's noise in one call (trial i is node i + 1: its stream does not depend on the count)
    clocks = np.empty((n, steps + 2))
    clocks[0] = node_clock_error_s(preset(sc.leader_oscillator), steps, dt, child_seed(base, _NODE, 0), 1)[0]
    clocks[1:] = node_clock_error_s(preset(sc.oscillator), steps, dt, child_seed(base, _NODE, 1), n - 1)
    for i in range(n):
        r = child_rng(base, _NODE, 2, i)
        clocks[i] += sc.initial_time_sigma_s * r.standard_normal() + sc.initial_frequency_sigma * r.standard_normal() * t
    links = neighbour_links(pos, sc.neighbours, sc.radio_range_m)
    return {"positions_m": pos, "velocities_m_s": vel, "links": links, "clocks_s": clocks}


def _alive(sc: SwarmScenario, qualities) -> np.ndarray:
    """Who is there (nodes, steps): everyone, but the leader elected at ``leader_loss_at_s`` leaves then (the
    leader the election chose, which is node 0 only where node 0 has the best clock)."""
    alive = np.ones((sc.nodes, sc.steps), dtype=bool)
    if sc.leader_loss_at_s is not None:
        k = int(round(sc.leader_loss_at_s / sc.interval_s))
        lead = leader_timeline(qualities, alive, sc.steps, sc.interval_s)[:min(k, sc.steps - 1) + 1]
        elected = lead[lead >= 0]
        if elected.size:  # the leader then (the last one elected before, while the election is pending)
            alive[elected[-1], k:] = False
    return alive


def _link_up(sc: SwarmScenario, truth: dict, seed) -> np.ndarray:
    """Each link's radio availability (L, steps), independent chains, within range, not cut off."""
    links = truth["links"]
    steps = sc.steps
    t = np.arange(steps) * sc.interval_s
    track = truth["positions_m"][:, None, :] + truth["velocities_m_s"][:, None, :] * t[None, :, None]
    up = in_range(track, links, sc.radio_range_m)
    up &= link_availability(links.shape[0], steps, child_seed(root_seed(seed), _AVAIL), mean_up_s=sc.mean_up_s,
                            mean_down_s=sc.mean_down_s, interval_s=sc.interval_s)
    for node, t0, t1 in sc.cut_off:
        cut = (t >= t0) & (t < t1)
        up[(links[:, 0] == node) | (links[:, 1] == node)] &= ~cut
    return up


def link_tasks(sc: SwarmScenario, truth: dict, up: np.ndarray, seed, *, chunk_links: int = 50) -> list[dict]:
    """The per-link work in chunks (plain picklable dicts)."""
    links = truth["links"]
    tasks = []
    for start in range(0, links.shape[0], int(chunk_links)):
        ids = np.arange(start, min(start + int(chunk_links), links.shape[0]))
        nodes = np.unique(links[ids])
        tasks.append({"scenario": sc, "ids": ids, "links": links[ids], "up": up[ids],
                      "positions_m": truth["positions_m"], "velocities_m_s": truth["velocities_m_s"],
                      "clocks_s": {int(i): truth["clocks_s"][i] for i in nodes},
                      "oscillators": {int(i): sc.oscillator_of(int(i)) for i in nodes}, "seed": root_seed(seed)})
    return tasks


def run_link_task(task: dict) -> dict:
    """Calibrate and run each link of a task: ``estimate_s``, ``sigma_s``, ``fault`` and ``usable`` (k, steps).

    The task's links are one batch (a trial per link) whose random streams are keyed by the links' indices
    in the swarm (``first_trial``), so any cut of the links into tasks draws the same numbers."""
    sc: SwarmScenario = task["scenario"]
    steps, link = sc.steps, sc.link
    ids, pairs, up = np.asarray(task["ids"]), np.asarray(task["links"]), np.asarray(task["up"], dtype=bool)
    k = ids.size
    out = {"ids": ids, "estimate_s": np.empty((k, steps)), "sigma_s": np.empty((k, steps)),
           "fault": np.empty((k, steps), dtype=bool), "usable": np.empty((k, steps), dtype=bool)}
    if k == 0:
        return out
    if np.any(np.diff(ids) != 1):
        raise ValueError("a task's links must be consecutive in the swarm's link list")
    first = int(ids[0])
    base = task["seed"]
    urt_dev = np.array([sc.prior.urt_sigma_s * child_rng(base, _LINK, int(l)).standard_normal() for l in ids])
    pa, pb = task["positions_m"][pairs[:, 0]], task["positions_m"][pairs[:, 1]]
    xa = np.vstack([task["clocks_s"][int(a)] for a in pairs[:, 0]])
    xb = np.vstack([task["clocks_s"][int(b)] for b in pairs[:, 1]])
    calib = _calibrate_links(sc, pa, pb, xb[:, 0] - xa[:, 0], urt_dev, child_seed(base, _LINK, 1_000_000), first)
    A = constant_velocity(pa, task["velocities_m_s"][pairs[:, 0]])
    B = constant_velocity(pb, task["velocities_m_s"][pairs[:, 1]])
    ex = simulate_exchanges(A, B, xa, xb, link, steps, child_seed(base, _LINK, 2_000_000),
                            urt_change_s=np.broadcast_to(urt_dev[:, None], (k, steps)), first_trial=first)
    Z = measurement_array(ex)
    Z[~up, :] = np.nan
    algorithm = task.get("algorithm", "doppler-kf")
    # one filter per pair of oscillators (the model differs), each over its links at once
    names = [(task["oscillators"][int(a)], task["oscillators"][int(b)]) for a, b in pairs]
    for pair in sorted(set(names)):
        rows = np.array([i for i, n in enumerate(names) if n == pair])
        oa, ob = preset(pair[0]), preset(pair[1])
        know = LinkKnowledge(link=link, oscillator=oa, prior=sc.prior, steps=steps, urt_s=calib.urt_s[rows],
                             calibration_sigma_s=calib.sigma_s[rows])
        fields = {}
        if algorithm == "doppler-kf":  # the two ends' own oscillators
            clock = ClockMarkovModel.for_link(oa, ob, link.interval_s, steps * link.interval_s)
            fields = {"h0_s": clock.h0_s, "hm1": clock.hm1, "hm2_per_s": clock.hm2_per_s}
        res = make_algorithm(algorithm, know, **fields).fit().run(Z[rows])
        out["estimate_s"][rows] = res.offset_s
        out["sigma_s"][rows] = res.uncertainty_s
        out["fault"][rows] = res.node_state == FAULT
    out["usable"] = up & np.isfinite(Z[:, :, 0])
    return out


def _calibrate_links(sc, pa, pb, offsets_s, urt_dev, seed, first_trial: int):
    """The links' URT calibrations: both nodes at rest at their initial places, GNSS time references (each
    link's streams keyed by its index in the swarm)."""
    cal = sc.calibration
    link = replace(sc.link, interval_s=cal.reference_interval_s)
    steps = cal.comparisons
    k = offsets_s.size
    base = root_seed(seed)
    a, b = constant_velocity(pa, np.zeros((k, 3))), constant_velocity(pb, np.zeros((k, 3)))
    # the clocks' own wander is in the GNSS reference too and cancels in the calibration: left out here
    ca = np.zeros((k, steps + 2))
    cb = ca + offsets_s[:, None]
    ex = simulate_exchanges(a, b, ca, cb, link, steps, child_seed(base, 2),
                            urt_change_s=np.broadcast_to(urt_dev[:, None], (k, steps)), first_trial=first_trial)
    noise = np.vstack([child_rng(base, 3, first_trial + i).standard_normal(steps) for i in range(k)])
    ref = ex.offset_s + cal.reference_sigma_s * np.sqrt(2.0) * noise
    return calibrate_urt(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s, ex.a_los_velocity_m_s,
                         link.toa_sigma_at(ex.snr_db), ref, t_s=ex.t_s, urt_jitter_s=link.urt_jitter_s,
                         reference_sigma_s=cal.reference_sigma_s)


def _qualities(sc: SwarmScenario):
    qs = []
    for i in range(sc.nodes):
        acc, var = OSCILLATOR_QUALITY[sc.oscillator_of(i)]
        qs.append(ClockQuality(128, CLASS_HOLDOVER, acc, var, 128, i))
    return lambda k: qs


def run_swarm(sc: SwarmScenario, seed=0, *, scheduler: str | None = "serial", chunk_links: int = 50) -> SwarmRun:
    """Simulate the swarm (module docstring); ``scheduler``: "serial" (here), None (a LocalCluster) or
    ``tcp://HOST:PORT``; the numbers do not depend on it."""
    truth = swarm_truth(sc, child_seed(root_seed(seed), 0))
    up = _link_up(sc, truth, child_seed(root_seed(seed), 1))
    alive = _alive(sc, _qualities(sc))
    up &= alive[truth["links"][:, 0]] & alive[truth["links"][:, 1]]  # no exchange with a node that left
    tasks = link_tasks(sc, truth, up, child_seed(root_seed(seed), 2), chunk_links=chunk_links)
    if scheduler == "serial":
        parts = [run_link_task(t) for t in tasks]
    else:
        from chronofuse.experiments.sweep import _client

        client, cluster = _client(scheduler, len(tasks))
        try:
            parts = client.gather(client.map(run_link_task, tasks, pure=False))
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    L, steps = truth["links"].shape[0], sc.steps
    merged = {k: np.empty((L, steps), dtype=bool if k in ("fault", "usable") else float)
              for k in ("estimate_s", "sigma_s", "fault", "usable")}
    for part in parts:
        for k in merged:
            merged[k][part["ids"]] = part[k]
    leader = leader_timeline(_qualities(sc), heard(alive, truth["links"], up), steps, sc.interval_s)
    time = compose_network_time(truth["links"], merged["estimate_s"], merged["sigma_s"], merged["usable"], leader,
                                alive, link_fault=merged["fault"], topology=sc.topology,
                                leader_weight=sc.leader_weight, interval_s=sc.interval_s)
    return SwarmRun(time=time, clocks_s=truth["clocks_s"][:, :steps], links=truth["links"], usable=merged["usable"],
                    alive=alive)


# --- the main job's leader-and-followers call -------------------------------------------------------------


@dataclass(frozen=True)
class SwarmResult(FrozenResult):
    """``t_s`` (steps,); ``to_leader_s`` and ``to_true_s`` (followers, steps): each follower's corrected time
    error to the leader and to true time; ``leader_s`` (steps,): the leader's own error to true time;
    ``link_up`` (followers, steps); ``parents`` (followers,) (0 = leader, i = follower i); ``state`` and
    ``sigma_s`` (followers, steps): each follower's state code and uncertainty."""

    t_s: np.ndarray
    to_leader_s: np.ndarray
    to_true_s: np.ndarray
    leader_s: np.ndarray
    link_up: np.ndarray
    parents: np.ndarray
    state: np.ndarray = field(default=None)
    sigma_s: np.ndarray = field(default=None)


def leader_clock_s(steps: int, interval_s: float, seed, *, oscillator: str = "ocxo", gnss_sigma_s: float = 1e-9,
                   loss_start_s: float | None = None, loss_duration_s: float = 3600.0) -> np.ndarray:
    """A GNSS-disciplined leader's time error, s, shape (steps + 2,): white ``gnss_sigma_s`` while GNSS is
    good; from ``loss_start_s`` for ``loss_duration_s`` the oscillator runs free (holdover: its own noise and
    aging from the loss instant, no initial frequency error); then disciplined again."""
    base = root_seed(seed)
    m = int(steps) + 2
    x = gnss_sigma_s * np.random.default_rng(child_seed(base, 0)).standard_normal(m)
    if loss_start_s is not None:
        free = node_clock_error_s(preset(oscillator), steps, interval_s, child_seed(base, 1), 1)[0]
        t = np.arange(m) * interval_s
        lost = (t >= loss_start_s) & (t < loss_start_s + loss_duration_s)
        if lost.any():
            i0 = int(np.argmax(lost))
            x[lost] = x[i0] + free[lost] - free[i0]
    return x


def link_availability(links: int, steps: int, seed, *, mean_up_s: float = np.inf, mean_down_s: float = 10.0,
                      interval_s: float = 1.0) -> np.ndarray:
    """Links that come and go: a two-state Markov chain per link (mean up and down times, s); shape
    (links, steps), True = up; all up when ``mean_up_s`` is infinite. Link ``l`` draws from
    ``child_seed(seed, l)``: its chain does not depend on how many links there are."""
    if not np.isfinite(mean_up_s):
        return np.ones((links, steps), dtype=bool)
    check_scalar(mean_up_s, "mean_up_s", min_val=0.0, include_min=False)
    check_scalar(mean_down_s, "mean_down_s", min_val=0.0, include_min=False)
    p_fail, p_fix = min(1.0, interval_s / mean_up_s), min(1.0, interval_s / mean_down_s)
    base = root_seed(seed)
    u = np.vstack([child_rng(base, l).random(steps) for l in range(int(links))]) if links else np.zeros((0, steps))
    up = np.ones((links, steps), dtype=bool)  # up at the start (a filter needs a first exchange)
    for k in range(1, steps):
        up[:, k] = np.where(up[:, k - 1], u[:, k] >= p_fail, u[:, k] < p_fix)
    return up


def follow_leader(leader_s, *, interval_s: float = 1.0, parents=(0, 0, 0), distances_m=(20e3, 50e3, 80e3),
                  velocities_m_s=(5.0, -8.0, 12.0), link: LinkModel | None = None, oscillator: str = "ocxo",
                  leader_oscillator: str = "ocxo", algorithm: str = "doppler-kf", link_up=None, topology: str = "tree", leader_weight: float = 0.5,
                  calibration: CalibrationConfig = CalibrationConfig(), prior: LinkPrior = LinkPrior(skew_sigma=1e-9),
                  seed=0) -> SwarmResult:
    """Followers keeping a given leader's time over two-way links (the main job's call).

    ``leader_s`` (steps + 2,): the leader's time error to true time. Follower ``i`` (1-based) follows
    ``parents[i-1]`` (0 = the leader; parents come first) at ``distances_m[i-1]`` moving radially at
    ``velocities_m_s[i-1]``; every link runs ``algorithm`` (one without an uncertainty, unlike ``doppler-kf``,
    never lets a follower report LOCKED); the followers run ``oscillator``, the leader's clock (its disciplined
    oscillator) is modelled as ``leader_oscillator``. Each link is calibrated (never the true URT); ``link_up`` (followers, steps)
    takes links down; ``topology="consensus"`` adds peer links between followers (their own availability,
    independent of the links to the parents).
    """
    x_l = check_array(leader_s, "leader_s", ndim=1)
    steps = x_l.size - 2
    check_scalar(steps, "steps", min_val=2, integer=True)
    check_choice(topology, "topology", ("tree", "consensus"))
    parents = np.asarray(parents, dtype=np.int64)
    n = parents.size
    if np.any(parents < 0) or np.any(parents >= np.arange(1, n + 1)):
        raise ValueError(f"parents == {parents.tolist()}, must be 0 (leader) or an earlier follower")
    link = LinkModel(interval_s=interval_s) if link is None else link
    up = np.ones((n, steps), dtype=bool) if link_up is None else np.asarray(link_up, dtype=bool)
    if up.shape != (n, steps):
        raise ValueError(f"link_up has shape {up.shape}, must be ({n}, {steps})")
    base = root_seed(seed)
    osc = preset(oscillator)
    xf = node_clock_error_s(osc, steps, interval_s, child_seed(base, 0), n)
    clocks = np.vstack([x_l[None, :], xf])
    # node positions along a line from the leader (radial geometry), each follower from its parent
    d = np.zeros(n + 1)
    v = np.zeros(n + 1)
    for i in range(n):
        d[i + 1] = d[parents[i]] + distances_m[i]
        v[i + 1] = v[parents[i]] + velocities_m_s[i]
    pos = np.column_stack([d, np.zeros(n + 1), np.zeros(n + 1)])
    vel = np.column_stack([v, np.zeros(n + 1), np.zeros(n + 1)])
    links = [(int(parents[i]), i + 1) for i in range(n)]
    avail = [up[i] for i in range(n)]
    if topology == "consensus":
        for i in range(1, n + 1):
            for j in range(i + 1, n + 1):
                links.append((i, j))
                avail.append(link_availability(1, steps, child_seed(base, 3, i, j), mean_up_s=600.0,
                                               mean_down_s=30.0, interval_s=interval_s)[0])  # peer links: own radios
    links = np.array(links, dtype=np.int64)
    sc = SwarmScenario(nodes=n + 1, duration_s=steps * interval_s, interval_s=interval_s, oscillator=oscillator,
                       snr_db=link.snr_db, prior=prior, calibration=calibration, topology=topology,
                       leader_weight=leader_weight)
    task = {"scenario": replace(sc), "ids": np.arange(len(links)), "links": links, "up": np.array(avail),
            "positions_m": pos, "velocities_m_s": vel, "clocks_s": {i: clocks[i] for i in range(n + 1)},
            "oscillators": {i: leader_oscillator if i == 0 else oscillator for i in range(n + 1)},
            "seed": child_seed(base, 1)}
    task["algorithm"] = algorithm
    part = run_link_task(task)
    alive = np.ones((n + 1, steps), dtype=bool)
    leader = np.zeros(steps, dtype=np.int64)
    gnss = np.zeros((n + 1, steps), dtype=bool)
    gnss[0] = True  # the leader's time (its GNSS-disciplined clock) is the network's time
    time = compose_network_time(links, part["estimate_s"], part["sigma_s"], part["usable"], leader, alive, gnss=gnss,
                                link_fault=part["fault"], topology=topology, leader_weight=leader_weight,
                                interval_s=interval_s)
    x = clocks[1:, :steps] - time.correction_s[1:]
    return SwarmResult(t_s=np.arange(steps) * interval_s, to_leader_s=x - x_l[:steps], to_true_s=x,
                       leader_s=x_l[:steps].copy(), link_up=up, parents=parents, state=time.state[1:],
                       sigma_s=time.sigma_s[1:])
