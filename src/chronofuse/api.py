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
    theobr,
    theoh,
    tie_rms,
    totdev,
    ttotdev,
)
from chronofuse.analysis.stability.taus import averaging_factors, tau_grid
from chronofuse.analysis.theory import adev_theory, avar_components, corrected_pps_adev
from chronofuse.estimation.filter import FilterResult, KalmanFilter
from chronofuse.estimation.interface import Estimator, FrozenResult, compare_streaming_to_batch, pick_inputs
from chronofuse.estimation.null import HoldLastEstimator
from chronofuse.estimation.process import ClockProcess
from chronofuse.estimation.rts import SmootherResult, rts_smooth
from chronofuse.discipline.chain import ChainConfig, GnssdoRun, discipline_run
from chronofuse.discipline.consensus import apply_leap, utc_consensus
from chronofuse.discipline.counter import MultiPhaseCounter
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.fusion import InverseVarianceFusion
from chronofuse.discipline.holdover import clairvoyant_holdover_error, holdover_error
from chronofuse.discipline.kalman import KalmanServo
from chronofuse.discipline.kalman_adaptive import AdaptiveKalmanServo
from chronofuse.discipline.kalman_gated import GatedKalmanServo
from chronofuse.discipline.kalman_huber import HuberKalmanServo
from chronofuse.discipline.loop import close_loop
from chronofuse.discipline.pi import PiServo
from chronofuse.discipline.qualification import Qualification, usable_epochs
from chronofuse.discipline.null import NullServo
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.smoothing import smooth_run
from chronofuse.discipline.states import State, StateConfig, StateMachine
from chronofuse.experiments.gnssdo import GnssdoSetup, run_gnssdo
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
from chronofuse.io.capture_series import read_clock_series
from chronofuse.io.clockbias import read_clock_bias
from chronofuse.io.grid import GridPlacer
from chronofuse.record import EpochRecord, Provenance
from chronofuse.estimation.pipeline import Pipeline
from chronofuse.integrity.watch import ClockWatch, DetectionSettings, detection_pipeline, watch_record
from chronofuse.integrity.live import StreamDetection
from chronofuse.io.records import ClockRecord, read_record
from chronofuse.io.rinex import channel_clock_biases, read_gps_navigation, read_gps_observations
from chronofuse.io.rinex_clock import read_station_clocks
from chronofuse.io.stable32 import read_stable32_table
from chronofuse.io.ubx import read_nav_clock
from chronofuse.models.imu import IMU_GRADES, ImuModel, SensorErrors, imu_grade, simulate_imu
from chronofuse.io.inspect import Capture, read_bytes, read_capture, summarize
from chronofuse.io.rinex_epochs import read_rinex_clock_epochs, read_rinex_observation_epochs
from chronofuse.io.sources import FileSource, GpsdSource, SerialSource, SourceGroup, TcpSource, parse_source
from chronofuse.io.sources_decode import GpsdJsonDecoder, StreamDecoder
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.log import EpochLog
from chronofuse.monitor.summary import read_session
from chronofuse.models.noise import power_law_noise
from chronofuse.positioning.ins import InsState, propagate
from chronofuse.positioning.loose import CoupledResult, LooselyCoupled, smooth
from chronofuse.positioning.scenario import DriveData, simulate_drive
from chronofuse.gnss.constellation import CONSTELLATIONS, constellation
from chronofuse.gnss.lsq_position import PositionFix, least_squares_position
from chronofuse.models.oscillator import OscillatorModel, PowerLaw, simulate_oscillator
from chronofuse.models.oscillator_presets import PRESETS, preset
from chronofuse.epochs import ReceiverEpochs
from chronofuse.models.environment import ENVIRONMENTS, ReceiverEnvironment, receiver_environment
from chronofuse.models.receiver import ReceiverTruth, simulate_receivers
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.validation import ChronofuseError, InputDataError
from chronofuse.models.kinematics import Trajectory, constant_acceleration, constant_velocity, manoeuvre
from chronofuse.models.link import Exchanges, LinkModel, simulate_exchanges
from chronofuse.sync.base import SyncResult, measurement_array
from chronofuse.sync.pcrb import link_pcrb
from chronofuse.sync.registry import ALGORITHM_NAMES as SYNC_ALGORITHMS
from chronofuse.sync.registry import make_algorithm as make_sync_algorithm
from chronofuse.experiments.swarm import LinkScenario, run_link, simulate_scenario
from chronofuse.experiments.swarm_network import SwarmResult, follow_leader, leader_clock_s, link_availability

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
    "ImuModel",
    "SensorErrors",
    "IMU_GRADES",
    "imu_grade",
    "simulate_imu",
    # GNSS models and positioning
    "CONSTELLATIONS",
    "constellation",
    "least_squares_position",
    "PositionFix",
    "InsState",
    "propagate",
    "LooselyCoupled",
    "CoupledResult",
    "smooth",
    "DriveData",
    "simulate_drive",
    # real data in
    "ClockRecord",
    "read_record",
    "read_nav_clock",
    "EpochRecord",
    "Provenance",
    "GridPlacer",
    "Pipeline",
    "DetectionSettings",
    "detection_pipeline",
    "watch_record",
    "ClockWatch",
    "StreamDetection",
    "read_clock_series",
    "read_clock_bias",
    "read_stable32_table",
    "read_gps_observations",
    "read_gps_navigation",
    "read_capture",
    "read_bytes",
    "Capture",
    "summarize",
    "read_rinex_observation_epochs",
    "read_rinex_clock_epochs",
    "FileSource",
    "SerialSource",
    "TcpSource",
    "GpsdSource",
    "SourceGroup",
    "parse_source",
    "StreamDecoder",
    "GpsdJsonDecoder",
    # monitor
    "Monitor",
    "MonitorSettings",
    "EpochLog",
    "read_session",
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
    "theobr",
    "theoh",
    "tie_rms",
    "mtie",
    "frequency_to_phase",
    "phase_to_frequency",
    "averaging_factors",
    "tau_grid",
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
    # discipline (GNSSDO)
    "Qualification",
    "usable_epochs",
    "MultiPhaseCounter",
    "Dac",
    "Servo",
    "NullServo",
    "PiServo",
    "KalmanServo",
    "AdaptiveKalmanServo",
    "GatedKalmanServo",
    "HuberKalmanServo",
    "close_loop",
    "InverseVarianceFusion",
    "utc_consensus",
    "apply_leap",
    "State",
    "StateConfig",
    "StateMachine",
    "holdover_error",
    "clairvoyant_holdover_error",
    "smooth_run",
    "ChainConfig",
    "GnssdoRun",
    "discipline_run",
    "StreamingMonitor",
    "EpochVerdict",
    "stream_verdicts",
    "repair_clock_steering",
    "read_station_clocks",
    # experiments
    "GnssdoSetup",
    "run_gnssdo",
    "Scenario",
    "load_scenario",
    "parse_scenario",
    "run_scenario",
    # swarm sync (seed 001)
    "Trajectory",
    "constant_velocity",
    "constant_acceleration",
    "manoeuvre",
    "LinkModel",
    "Exchanges",
    "simulate_exchanges",
    "measurement_array",
    "SyncResult",
    "SYNC_ALGORITHMS",
    "make_sync_algorithm",
    "link_pcrb",
    "LinkScenario",
    "simulate_scenario",
    "run_link",
    "SwarmResult",
    "follow_leader",
    "leader_clock_s",
    "link_availability",
    # errors
    "ChronofuseError",
    "InputDataError",
]
