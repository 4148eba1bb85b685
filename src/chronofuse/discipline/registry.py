"""The servos by name: :data:`SERVOS`, the one registry of loop controllers (:mod:`chronofuse.registry`).

=============== ============================================================================
null            the do-nothing baseline: the free-running oscillator (:mod:`.null`)
pi              PI on the phase offset, gains or a loop bandwidth (:mod:`.pi`)
kalman          Kalman servo on [phase, frequency, drift] (:mod:`.kalman`)
adaptive-kalman the weighted adaptive Kalman servo of the GNSSDO paper (:mod:`.kalman_adaptive`)
gated-kalman    Kalman servo behind a chi-square innovation gate (:mod:`.kalman_gated`)
huber-kalman    Kalman servo with a Huber-weighted update (:mod:`.kalman_huber`)
=============== ============================================================================

``SERVOS.create(name, context={...}, **settings)`` builds an unfitted servo. The context is what the
caller knows about the loop, offered to every member: ``interval_s`` (the sample interval, s) and ``dac``
(a :class:`~chronofuse.discipline.dac.Dac` or None) go to every servo; the Kalman servos also take the
design's ``h`` (the oscillator's :class:`~chronofuse.models.oscillator.PowerLaw`) and
``measurement_sigma_s`` (the reference's white noise, s) from it when their settings leave them None, and
otherwise learn them in ``fit``. Settings are each member's config fields (``SERVOS.describe(name)``);
one a member does not have is refused by name.

A plugin servo is one module (a :class:`~chronofuse.discipline.servo.Servo` subclass, its config and an
:class:`~chronofuse.registry.Entry`) and one entry point in the group ``chronofuse.servos``; its class is
built as ``cls(**settings, interval_s=..., dac=...)``.
"""

from __future__ import annotations

from chronofuse.discipline.kalman import KalmanServo, KalmanServoConfig, build_kalman
from chronofuse.discipline.kalman_adaptive import AdaptiveKalmanServo, AdaptiveKalmanServoConfig
from chronofuse.discipline.kalman_gated import GatedKalmanServo, GatedKalmanServoConfig
from chronofuse.discipline.kalman_huber import HuberKalmanServo, HuberKalmanServoConfig
from chronofuse.discipline.null import NullServo, NullServoConfig
from chronofuse.discipline.pi import PiServo, PiServoConfig, build_pi
from chronofuse.registry import Entry, Registry

__all__ = ["SERVOS"]

SERVOS = Registry("servos", shared=("interval_s", "dac"))
SERVOS.add("null", Entry(NullServo, NullServoConfig, "never corrects: the free-running oscillator"))
SERVOS.add("pi", Entry(PiServo, PiServoConfig, "PI on the phase offset (gains, or a loop bandwidth)", build_pi))
SERVOS.add("kalman", Entry(KalmanServo, KalmanServoConfig, "Kalman servo on [phase, frequency, drift]",
                           build_kalman(KalmanServo)))
SERVOS.add("adaptive-kalman", Entry(AdaptiveKalmanServo, AdaptiveKalmanServoConfig,
                                    "weighted adaptive Kalman servo (R scaled by the innovations' spread)",
                                    build_kalman(AdaptiveKalmanServo)))
SERVOS.add("gated-kalman", Entry(GatedKalmanServo, GatedKalmanServoConfig,
                                 "Kalman servo behind a chi-square innovation gate", build_kalman(GatedKalmanServo)))
SERVOS.add("huber-kalman", Entry(HuberKalmanServo, HuberKalmanServoConfig,
                                 "Kalman servo with a Huber-weighted update", build_kalman(HuberKalmanServo)))
