"""The public surface of chronofuse, in one place: ``from chronofuse.api import ...``.

Truth models -> measurements -> analysis -> report, in the order data flows.
"""

from __future__ import annotations

from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.stability import (
    STATISTICS,
    Deviation,
    adev,
    compute,
    frequency_to_phase,
    hdev,
    htotdev,
    mdev,
    mtie,
    mtotdev,
    oadev,
    ohdev,
    phase_to_frequency,
    tdev,
    theo1,
    tie_rms,
    totdev,
    ttotdev,
)
from chronofuse.analysis.stability.taus import averaging_factors
from chronofuse.analysis.theory import adev_theory, avar_components, corrected_pps_adev
from chronofuse.estimation.filter import FilterResult, KalmanFilter
from chronofuse.estimation.interface import Estimator, FrozenResult, compare_streaming_to_batch, pick_inputs
from chronofuse.estimation.null import HoldLastEstimator
from chronofuse.estimation.process import ClockProcess
from chronofuse.estimation.rts import SmootherResult, rts_smooth
from chronofuse.experiments.main_job import run_scenario
from chronofuse.integrity.baselines import CusumDetector, ReferenceClockDetector, SingleEpochDetector
from chronofuse.integrity.detector import DetectionResult, HodDetector
from chronofuse.integrity.identification import identify
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.clock_events import repair_clock_steering
from chronofuse.integrity.live import stream_verdicts
from chronofuse.integrity.modes import detect_file
from chronofuse.integrity.streaming import EpochVerdict, StreamingMonitor
from chronofuse.experiments.scenario import Scenario, load_scenario, parse_scenario
from chronofuse.io.clockbias import ClockBiasInput, read_clock_bias
from chronofuse.io.records import ClockRecord, read_record
from chronofuse.io.rinex import channel_clock_biases, read_gps_navigation, read_gps_observations
from chronofuse.io.rinex_clock import read_station_clocks
from chronofuse.io.stable32 import read_stable32_table
from chronofuse.io.ubx import read_nav_clock
from chronofuse.models.noise import power_law_noise
from chronofuse.models.oscillator import PRESETS, OscillatorModel, PowerLaw, preset, simulate_oscillator
from chronofuse.epochs import ReceiverEpochs
from chronofuse.models.environment import ENVIRONMENTS, ReceiverEnvironment, receiver_environment
from chronofuse.models.receiver import ReceiverTruth, simulate_receivers
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.validation import ChronofuseError, InputDataError

__all__ = [
    # truth models
    "PowerLaw",
    "OscillatorModel",
    "PRESETS",
    "preset",
    "simulate_oscillator",
    "power_law_noise",
    "ReceiverModel",
    "ReceiverEnvironment",
    "ENVIRONMENTS",
    "receiver_environment",
    "simulate_receivers",
    "ReceiverTruth",
    "ReceiverEpochs",
    # real data in
    "ClockRecord",
    "read_record",
    "read_nav_clock",
    "ClockBiasInput",
    "read_clock_bias",
    "read_stable32_table",
    "read_gps_observations",
    "read_gps_navigation",
    # analysis
    "Deviation",
    "STATISTICS",
    "compute",
    "adev",
    "oadev",
    "mdev",
    "tdev",
    "hdev",
    "ohdev",
    "totdev",
    "mtotdev",
    "htotdev",
    "ttotdev",
    "theo1",
    "tie_rms",
    "mtie",
    "frequency_to_phase",
    "phase_to_frequency",
    "averaging_factors",
    "adev_theory",
    "avar_components",
    "corrected_pps_adev",
    "MASKS",
    # estimation
    "Estimator",
    "FrozenResult",
    "compare_streaming_to_batch",
    "pick_inputs",
    "KalmanFilter",
    "FilterResult",
    "rts_smooth",
    "SmootherResult",
    "HoldLastEstimator",
    "ClockProcess",
    # integrity
    "HodDetector",
    "DetectionResult",
    "SingleEpochDetector",
    "CusumDetector",
    "ReferenceClockDetector",
    "Anomaly",
    "inject",
    "channel_clock_biases",
    "identify",
    "detect_file",
    "StreamingMonitor",
    "EpochVerdict",
    "stream_verdicts",
    "repair_clock_steering",
    "read_station_clocks",
    # experiments
    "Scenario",
    "load_scenario",
    "parse_scenario",
    "run_scenario",
    # errors
    "ChronofuseError",
    "InputDataError",
]
