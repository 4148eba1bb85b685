"""One receiver clock watched for integrity: the detection pipeline and its two drivers, batch and live.

:func:`detection_pipeline` builds the four stages of :mod:`chronofuse.integrity.stages` (status gate, clock
repair, detector, latch) from :class:`DetectionSettings`. Two drivers run it over a gridded clock-bias
record (:class:`~chronofuse.record.EpochRecord` with ``clock_bias_s`` on a regular grid,
:class:`chronofuse.io.grid.GridPlacer`):

* :func:`watch_record` (batch: ``detect FILE``): fit on the training stretch, ``run`` over every epoch;
* :class:`ClockWatch` (live: ``detect -``, the monitor): chunks pushed as they arrive, one verdict per epoch.
  While the training stretch arrives its epochs go through the gate and the repair at once and are
  reported ``unavailable`` (``training``); at its end the detector and the latch are fitted on it exactly as
  the batch driver fits them, the training epochs are stepped through them silently (filling the window
  and the latch's history), and every later epoch is stepped as it comes.

Both give the same columns for every epoch (:meth:`ClockWatch.result` is the batch result of what was
pushed), so the same data get the same alarms, states and clock events on every path. Every column is the
same bit for bit but the statistic, which the batch driver computes for all windows in one matrix product and
the live one window by window: the two sums run in different orders and differ by a few units in the last
place, within the rounding bound that tests/integrity/test_stream_equals_batch.py holds every epoch to (under
1e-12 of the threshold), so no verdict can differ.

Training stretch: the epochs ``t_ns - t0 < train_s`` (``t0`` the first epoch of the grid), or the first
``train_epochs`` slots of the grid; it is fitted when at least ``window + 3`` of its epochs are valid.
Without a training stretch the noise model (``h0``, ``hm2``, ``sigma_rho_m``) must be complete.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from chronofuse.estimation.pipeline import Pipeline, PipelineResult, stack_steps
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.receiver_status import DEFAULT_MAX_TIME_ACC_S
from chronofuse.integrity.stages import ClockRepair, DetectorStage, Latch, StatusGate
from chronofuse.integrity.streaming import EpochVerdict, epoch_events
from chronofuse.validation import check_scalar

__all__ = ["DetectionSettings", "TRAINING_CONFIDENCE", "Watched", "ClockWatch", "detection_pipeline",
           "watch_record"]

#: With a training stretch, the detectors keep P_fa at or below nominal in this share of trainings (the
#: ``confidence`` of :class:`~chronofuse.integrity.detector.HodDetector`).
TRAINING_CONFIDENCE = 0.9

#: The columns a verdict is made of, beside ``t_ns``.
_PREPARED = ("status", "gated_bias_s", "repaired_bias_s", "clock_reset_s")
_TESTED = ("detector_input_s", "statistic", "threshold", "dof", "over", "state", "latch_event")


def _hod(interval_s: float, settings: DetectionSettings):
    return HodDetector(interval_s=interval_s, window=settings.window, pfa=settings.pfa, h0=settings.h0,
                       hm2=settings.hm2, sigma_rho_m=settings.sigma_rho_m,
                       confidence=TRAINING_CONFIDENCE if settings.trains else None)


@dataclass(frozen=True)
class DetectionSettings:
    """What a clock watch is given: the detector (``window`` in differences, ``pfa`` per epoch, the noise
    model ``h0`` (s), ``hm2`` (1/s), ``sigma_rho_m`` (m), any left None fitted on the training stretch of
    ``train_s`` seconds or ``train_epochs`` grid epochs), the status gate (``max_time_acc_s``, s; None: not
    used), the clock repair (``reset_tolerance_s``, s) and the latch (``clear_after`` epochs, default one
    window; ``clear_sigma``). ``detector``: a factory ``(interval_s, settings) -> detector`` with the
    estimator interface, the HOD chi-square test by default."""

    window: int = 20
    pfa: float = 1e-3
    h0: float | None = None
    hm2: float | None = None
    sigma_rho_m: float | None = None
    train_s: float | None = None
    train_epochs: int | None = None
    max_time_acc_s: float | None = DEFAULT_MAX_TIME_ACC_S
    reset_tolerance_s: float = 1e-4
    clear_after: int | None = None
    clear_sigma: float = 5.0
    detector: Callable | None = field(default=None, compare=False)

    def __post_init__(self):
        if self.train_s is not None:
            check_scalar(self.train_s, "train_s", min_val=0.0, include_min=False)
        if self.train_epochs is not None:
            check_scalar(self.train_epochs, "train_epochs", min_val=1, integer=True)
        if self.train_s is not None and self.train_epochs is not None:
            raise ValueError("give train_s or train_epochs, not both")
        if not self.trains and None in (self.h0, self.hm2, self.sigma_rho_m):
            raise ValueError("give the noise model (h0, hm2 and sigma_rho_m) or a training stretch (train_s)")
        if self.max_time_acc_s is not None:
            check_scalar(self.max_time_acc_s, "max_time_acc_s", min_val=0.0, include_min=False)

    @property
    def trains(self) -> bool:
        return self.train_s is not None or self.train_epochs is not None

    def in_training(self, t_ns: np.ndarray, t0_ns: int, interval_ns: int) -> np.ndarray:
        """Which epochs at ``t_ns`` belong to the training stretch of a grid starting at ``t0_ns``."""
        offset = np.asarray(t_ns, dtype=np.int64) - t0_ns
        if self.train_s is not None:
            return offset < round(self.train_s * 1e9)
        if self.train_epochs is not None:
            return offset < int(self.train_epochs) * interval_ns
        return np.zeros(offset.shape, dtype=bool)

    def make_detector(self, interval_s: float):
        return (self.detector or _hod)(interval_s, self)


def detection_pipeline(settings: DetectionSettings, interval_s: float) -> Pipeline:
    """The four stages (module docstring) for a grid of ``interval_s`` seconds, not fitted."""
    detector = settings.make_detector(interval_s)
    return Pipeline([
        ("status", StatusGate(settings.max_time_acc_s)),
        ("repair", ClockRepair(settings.reset_tolerance_s)),
        ("detector", DetectorStage(detector)),
        ("latch", Latch(detector, window=settings.window, clear_after=settings.clear_after,
                        clear_sigma=settings.clear_sigma)),
    ])


@dataclass(frozen=True)
class Watched:
    """A watched clock: ``result`` every column at every epoch (:class:`PipelineResult`), ``training`` (epochs,)
    the training stretch, ``fitted`` whether the detector could be fitted (``reasons`` why not), ``detector``,
    ``outlier_t_ns`` the training epochs the detector left out of its fit."""

    result: PipelineResult
    training: np.ndarray
    fitted: bool
    reasons: tuple[str, ...]
    detector: object
    interval_s: float
    outlier_t_ns: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def n_training(self) -> int:
        return int(self.training.sum())


def _inputs(record) -> dict:
    frame = record.frame()
    out = {"t_ns": frame["t_ns"], "valid": frame["valid"], "clock_bias_s": frame["clock_bias_s"]}
    if "time_acc_s" in frame:
        out["time_acc_s"] = frame["time_acc_s"]
    return out


def _fit(pipeline: Pipeline, train: dict, settings: DetectionSettings) -> tuple[bool, tuple[str, ...]]:
    """Fit the detector and latch on the prepared training columns; ``(fitted, reasons it was not)``."""
    if not settings.trains:
        pipeline["detector"].fit()
        pipeline["latch"].fit()
        return True, ()
    valid = int(np.isfinite(train["repaired_bias_s"]).sum())
    need = int(settings.window) + 3
    if valid < need:
        stretch = f"the training stretch (train_s) of {settings.train_s:g} s" if settings.train_s is not None else \
            f"train_epochs {settings.train_epochs}"
        return False, (f"training failed: {stretch} holds {valid} valid epochs; need at least window + 3 = {need}",)
    try:
        pipeline["detector"].fit(train)
    except (ValueError, np.linalg.LinAlgError) as err:
        return False, (f"training failed: {err}",)
    pipeline["latch"].fit()
    return True, ()


def _untested(prepared: dict, training: np.ndarray) -> dict:
    n = training.size
    return {"detector_input_s": np.full(n, np.nan), "statistic": np.full(n, np.nan), "threshold": np.full(n, np.nan),
            "dof": np.zeros(n, dtype=np.int64), "over": np.zeros(n, dtype=bool),
            "state": np.full(n, "unavailable", dtype=object), "latch_event": np.full(n, "", dtype=object)}


def watch_record(record, settings: DetectionSettings) -> Watched:
    """The batch driver (module docstring) over a gridded clock-bias record (``lead == ()``)."""
    interval_s = record.interval_ns / 1e9
    pipeline = detection_pipeline(settings, interval_s)
    frame = _inputs(record)
    training = settings.in_training(record.t_ns, int(record.t_ns[0]), record.interval_ns)
    frame["training"] = training
    prepare = Pipeline(pipeline.stages[:2])
    prepared = prepare.run(frame).columns
    n_train = int(training.sum())
    fitted, reasons = _fit(pipeline, {k: v[:n_train] for k, v in prepared.items()}, settings)
    if fitted:
        result = Pipeline(pipeline.stages[2:]).run(prepared)
    else:
        result = PipelineResult({**prepared, **_untested(prepared, training)})
    return Watched(result, training, fitted, reasons, pipeline["detector"].detector, interval_s, _outliers(pipeline))


def _outliers(pipeline: Pipeline) -> np.ndarray:
    return getattr(pipeline["detector"], "outlier_t_ns_", np.zeros(0, dtype=np.int64))


class ClockWatch:
    """The live driver (module docstring): ``push`` gridded chunks, get one :class:`EpochVerdict` per epoch.

    Training epochs are reported as they arrive (``unavailable``, event ``training``; their statistics are
    computed when the stretch ends, and :meth:`result` holds those); every later epoch's verdict is final.
    """

    def __init__(self, settings: DetectionSettings):
        self.settings = settings
        self.pipeline: Pipeline | None = None
        self._t0: int | None = None
        self._interval_ns: int | None = None
        self._rows: list = []  # every epoch's columns, in order
        self._training_rows: list[int] = []
        self._phase = "start"  # "training", "testing" or "failed"
        self.reasons: tuple[str, ...] = ()

    def push(self, record) -> list[EpochVerdict]:
        """Step a gridded chunk (``lead == ()``) through the pipeline; the verdicts of its epochs."""
        if record is None or record.n_epochs == 0:
            return []
        if self.pipeline is None:
            self.begin(int(record.t_ns[0]), int(record.interval_ns))
        frame = _inputs(record)
        names = list(frame)
        return [self.step({name: frame[name][k] for name in names}) for k in range(record.n_epochs)]

    def begin(self, t0_ns: int, interval_ns: int) -> None:
        """Start a grid at ``t0_ns`` of ``interval_ns`` (what the first pushed chunk does)."""
        self._start_grid(t0_ns, interval_ns)

    def step(self, epoch: dict) -> EpochVerdict:
        """One epoch of the grid (``t_ns``, ``clock_bias_s``, ``valid``, optionally ``time_acc_s``) after
        :meth:`begin`: its verdict."""
        epoch = dict(epoch)
        epoch["training"] = bool(self.settings.in_training(np.int64(epoch["t_ns"]), self._t0, self._interval_ns))
        if self._phase == "training" and not epoch["training"]:
            self._end_training()
        return self._step(epoch)

    def close(self) -> list[EpochVerdict]:
        """End of the stream: a training stretch still open is fitted now (its epochs keep their verdicts)."""
        if self._phase == "training":
            self._end_training()
        return []

    def _start_grid(self, t0_ns: int, interval_ns: int) -> None:
        self._t0, self._interval_ns = int(t0_ns), int(interval_ns)
        self.pipeline = detection_pipeline(self.settings, self._interval_ns / 1e9)
        if self.settings.trains:
            self._phase = "training"
        else:
            _fit(self.pipeline, {}, self.settings)
            self._phase = "testing"

    def _step(self, epoch: dict) -> EpochVerdict:
        stages = self.pipeline.stages
        values = dict(epoch)
        for _, stage in stages[:2]:
            values.update(stage.step(values))
        if self._phase == "testing":
            for _, stage in stages[2:]:
                values.update(stage.step(values))
        else:
            values.update({"detector_input_s": math.nan, "statistic": math.nan, "threshold": math.nan, "dof": 0,
                           "over": False, "state": "unavailable", "latch_event": ""})
            if self._phase == "training":
                self._training_rows.append(len(self._rows))
        self._rows.append(values)
        return _verdict(values, self._phase)

    def _end_training(self) -> None:
        rows = [self._rows[i] for i in self._training_rows]
        train = stack_steps(rows, ("t_ns", *_PREPARED)) if rows else {}
        fitted, self.reasons = _fit(self.pipeline, train, self.settings)
        if not fitted:
            self._phase = "failed"
            return
        for row in rows:  # the training epochs through the detector and the latch, silently
            values = dict(row)
            for _, stage in self.pipeline.stages[2:]:
                values.update(stage.step(values))
            row.update(values)
        self._phase = "testing"

    def result(self) -> Watched:
        """Everything pushed so far as the batch driver gives it (call :meth:`close` first)."""
        names = ("t_ns", "valid", "clock_bias_s", *_PREPARED, *_TESTED)
        columns = stack_steps(self._rows, names)
        training = np.array([bool(r["training"]) for r in self._rows], dtype=bool)
        detector = None if self.pipeline is None else self.pipeline["detector"].detector
        outliers = np.zeros(0, dtype=np.int64) if self.pipeline is None else _outliers(self.pipeline)
        return Watched(PipelineResult(columns), training, self._phase == "testing", self.reasons, detector,
                       self._interval_ns / 1e9 if self._interval_ns else math.nan, outliers)


def _verdict(values: dict, phase: str) -> EpochVerdict:
    return EpochVerdict(int(values["t_ns"]), float(values["statistic"]), float(values["threshold"]),
                        bool(values["over"]) and not bool(values["training"]), str(values["state"]),
                        epoch_events(values["status"], float(values["clock_reset_s"]), values["latch_event"],
                                     bool(values["training"]), phase == "failed"))
