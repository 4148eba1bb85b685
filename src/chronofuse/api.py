"""The public surface of chronofuse, in one place: ``from chronofuse.api import ...``.

Truth models -> measurements -> analysis -> report, in the order data flows.

Lazy: importing this module imports nothing else; each name loads its module on first use (PEP 562), so
``import chronofuse.api`` costs about what the interpreter's start does, and a script pays only for the
parts it uses. ``dir()`` and ``__all__`` list every name.
"""

from __future__ import annotations

import importlib

#: Public name -> the module that defines it (or (module, name there) where the public name differs).
_EXPORTS: dict[str, str | tuple[str, str]] = {
    # truth models
    "PowerLaw": "chronofuse.models.oscillator",
    "OscillatorModel": "chronofuse.models.oscillator",
    "PRESETS": "chronofuse.models.oscillator_presets",
    "preset": "chronofuse.models.oscillator_presets",
    "simulate_oscillator": "chronofuse.models.oscillator",
    "power_law_noise": "chronofuse.models.noise",
    "ReceiverModel": "chronofuse.models.receiver_model",
    "ReceiverEnvironment": "chronofuse.models.environment",
    "ENVIRONMENTS": "chronofuse.models.environment",
    "receiver_environment": "chronofuse.models.environment",
    "simulate_receivers": "chronofuse.models.receiver",
    "ReceiverTruth": "chronofuse.models.receiver",
    "ReceiverEpochs": "chronofuse.epochs",
    "ImuModel": "chronofuse.models.imu",
    "SensorErrors": "chronofuse.models.imu",
    "IMU_GRADES": "chronofuse.models.imu",
    "imu_grade": "chronofuse.models.imu",
    "simulate_imu": "chronofuse.models.imu",
    # GNSS models and positioning
    "CONSTELLATIONS": "chronofuse.gnss.constellation",
    "constellation": "chronofuse.gnss.constellation",
    "least_squares_position": "chronofuse.gnss.lsq_position",
    "PositionFix": "chronofuse.gnss.lsq_position",
    "InsState": "chronofuse.positioning.ins",
    "propagate": "chronofuse.positioning.ins",
    "LooselyCoupled": "chronofuse.positioning.loose",
    "CoupledResult": "chronofuse.positioning.loose",
    "smooth": "chronofuse.positioning.loose",
    "DriveData": "chronofuse.positioning.scenario",
    "simulate_drive": "chronofuse.positioning.scenario",
    # real data in
    "ClockRecord": "chronofuse.io.records",
    "read_record": "chronofuse.io.records",
    "read_nav_clock": "chronofuse.io.ubx",
    "EpochRecord": "chronofuse.record",
    "Provenance": "chronofuse.record",
    "GridPlacer": "chronofuse.io.grid",
    "Pipeline": "chronofuse.estimation.pipeline",
    "DetectionSettings": "chronofuse.integrity.watch",
    "detection_pipeline": "chronofuse.integrity.watch",
    "watch_record": "chronofuse.integrity.watch",
    "ClockWatch": "chronofuse.integrity.watch",
    "StreamDetection": "chronofuse.integrity.live",
    "read_clock_series": "chronofuse.io.capture_series",
    "read_clock_bias": "chronofuse.io.clockbias",
    "read_stable32_table": "chronofuse.io.stable32",
    "write_stable32": "chronofuse.io.stable32_export",
    "LogSeries": "chronofuse.io.field_logs",
    "read_log": "chronofuse.io.field_logs",
    "series_record": "chronofuse.io.field_logs",
    "series_clock_bias": "chronofuse.io.field_logs",
    "read_gps_observations": "chronofuse.io.rinex",
    "read_gps_navigation": "chronofuse.io.rinex",
    "read_capture": "chronofuse.io.inspect",
    "read_bytes": "chronofuse.io.inspect",
    "Capture": "chronofuse.io.inspect",
    "summarize": "chronofuse.io.inspect",
    "read_rinex_observation_epochs": "chronofuse.io.rinex_epochs",
    "read_rinex_clock_epochs": "chronofuse.io.rinex_epochs",
    "FileSource": "chronofuse.io.sources",
    "SerialSource": "chronofuse.io.sources",
    "TcpSource": "chronofuse.io.sources",
    "GpsdSource": "chronofuse.io.sources",
    "SourceGroup": "chronofuse.io.sources",
    "parse_source": "chronofuse.io.sources",
    "StreamDecoder": "chronofuse.io.sources_decode",
    "GpsdJsonDecoder": "chronofuse.io.sources_decode",
    # monitor
    "Monitor": "chronofuse.monitor.engine",
    "MonitorSettings": "chronofuse.monitor.decisions",
    "EpochLog": "chronofuse.monitor.log",
    "read_session": "chronofuse.monitor.summary",
    # analysis
    "Deviation": "chronofuse.analysis.stability",
    "STATISTICS": "chronofuse.analysis.stability",
    "compute": "chronofuse.analysis.stability",
    "adev": "chronofuse.analysis.stability",
    "oadev": "chronofuse.analysis.stability",
    "mdev": "chronofuse.analysis.stability",
    "tdev": "chronofuse.analysis.stability",
    "hdev": "chronofuse.analysis.stability",
    "ohdev": "chronofuse.analysis.stability",
    "totdev": "chronofuse.analysis.stability",
    "mtotdev": "chronofuse.analysis.stability",
    "htotdev": "chronofuse.analysis.stability",
    "ttotdev": "chronofuse.analysis.stability",
    "theo1": "chronofuse.analysis.stability",
    "theobr": "chronofuse.analysis.stability",
    "theoh": "chronofuse.analysis.stability",
    "tie_rms": "chronofuse.analysis.stability",
    "mtie": "chronofuse.analysis.stability",
    "frequency_to_phase": "chronofuse.analysis.stability",
    "phase_to_frequency": "chronofuse.analysis.stability",
    "averaging_factors": "chronofuse.analysis.stability.taus",
    "tau_grid": "chronofuse.analysis.stability.taus",
    "adev_theory": "chronofuse.analysis.theory",
    "avar_components": "chronofuse.analysis.theory",
    "corrected_pps_adev": "chronofuse.analysis.theory",
    "MASKS": "chronofuse.analysis.masks",
    # estimation
    "Estimator": "chronofuse.estimation.interface",
    "FrozenResult": "chronofuse.estimation.interface",
    "compare_streaming_to_batch": "chronofuse.estimation.interface",
    "pick_inputs": "chronofuse.estimation.interface",
    "KalmanFilter": "chronofuse.estimation.filter",
    "FilterResult": "chronofuse.estimation.filter",
    "rts_smooth": "chronofuse.estimation.rts",
    "SmootherResult": "chronofuse.estimation.rts",
    "HoldLastEstimator": "chronofuse.estimation.null",
    "ClockProcess": "chronofuse.estimation.process",
    # integrity
    "HodDetector": "chronofuse.integrity.detector",
    "DetectionResult": "chronofuse.integrity.detector",
    "SingleEpochDetector": "chronofuse.integrity.baselines",
    "CusumDetector": "chronofuse.integrity.baselines",
    "ReferenceClockDetector": "chronofuse.integrity.baselines",
    "Anomaly": "chronofuse.integrity.inject",
    "inject": "chronofuse.integrity.inject",
    "channel_clock_biases": "chronofuse.io.rinex",
    "identify": "chronofuse.integrity.identification",
    "detect_file": "chronofuse.integrity.modes",
    # discipline (GNSSDO)
    "Qualification": "chronofuse.discipline.qualification",
    "usable_epochs": "chronofuse.discipline.qualification",
    "MultiPhaseCounter": "chronofuse.discipline.counter",
    "Dac": "chronofuse.discipline.dac",
    "Servo": "chronofuse.discipline.servo",
    "NullServo": "chronofuse.discipline.null",
    "PiServo": "chronofuse.discipline.pi",
    "KalmanServo": "chronofuse.discipline.kalman",
    "AdaptiveKalmanServo": "chronofuse.discipline.kalman_adaptive",
    "GatedKalmanServo": "chronofuse.discipline.kalman_gated",
    "HuberKalmanServo": "chronofuse.discipline.kalman_huber",
    "close_loop": "chronofuse.discipline.loop",
    "InverseVarianceFusion": "chronofuse.discipline.fusion",
    "utc_consensus": "chronofuse.discipline.consensus",
    "apply_leap": "chronofuse.discipline.consensus",
    "State": "chronofuse.discipline.states",
    "StateConfig": "chronofuse.discipline.states",
    "StateMachine": "chronofuse.discipline.states",
    "holdover_error": "chronofuse.discipline.holdover",
    "clairvoyant_holdover_error": "chronofuse.discipline.holdover",
    "smooth_run": "chronofuse.discipline.smoothing",
    "characterize": "chronofuse.discipline.characterize",
    "characterize_file": "chronofuse.discipline.characterize",
    "Characterization": "chronofuse.discipline.characterize",
    "read_oscillator_file": "chronofuse.discipline.characterize",
    "ChainConfig": "chronofuse.discipline.chain",
    "GnssdoRun": "chronofuse.discipline.chain",
    "discipline_run": "chronofuse.discipline.chain",
    "StreamingMonitor": "chronofuse.integrity.streaming",
    "EpochVerdict": "chronofuse.integrity.streaming",
    "stream_verdicts": "chronofuse.integrity.live",
    "repair_clock_steering": "chronofuse.integrity.clock_events",
    "read_station_clocks": "chronofuse.io.rinex_clock",
    # experiments
    "GnssdoSetup": "chronofuse.experiments.gnssdo",
    "run_gnssdo": "chronofuse.experiments.gnssdo",
    "Scenario": "chronofuse.experiments.scenario",
    "load_scenario": "chronofuse.experiments.scenario",
    "parse_scenario": "chronofuse.experiments.scenario",
    "run_scenario": "chronofuse.experiments.main_job",
    # swarm sync (the swarm paper)
    "Trajectory": "chronofuse.models.kinematics",
    "constant_velocity": "chronofuse.models.kinematics",
    "constant_acceleration": "chronofuse.models.kinematics",
    "manoeuvre": "chronofuse.models.kinematics",
    "LinkModel": "chronofuse.models.link",
    "Exchanges": "chronofuse.models.link",
    "simulate_exchanges": "chronofuse.models.link",
    "measurement_array": "chronofuse.sync.base",
    "SyncResult": "chronofuse.sync.base",
    "SYNC_ALGORITHMS": ("chronofuse.sync.registry", "ALGORITHM_NAMES"),
    "make_sync_algorithm": ("chronofuse.sync.registry", "make_algorithm"),
    "link_pcrb": "chronofuse.sync.pcrb",
    "LinkScenario": "chronofuse.experiments.swarm",
    "simulate_scenario": "chronofuse.experiments.swarm",
    "run_link": "chronofuse.experiments.swarm",
    "SwarmResult": "chronofuse.experiments.swarm_network",
    "follow_leader": "chronofuse.experiments.swarm_network",
    "leader_clock_s": "chronofuse.experiments.swarm_network",
    "link_availability": "chronofuse.experiments.swarm_network",
    # errors
    "ChronofuseError": "chronofuse.validation",
    "InputDataError": "chronofuse.validation",
    "InputError": "chronofuse.validation",
    "InputWarning": "chronofuse.validation",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    try:
        where = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    module, attr = (where, name) if isinstance(where, str) else where
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value  # the next access is a plain global
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
