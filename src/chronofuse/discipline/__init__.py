"""GNSS-disciplined oscillator (the GNSSDO paper): one idea per module.

qualification (is a receiver's 1PPS usable) -> counter (multi-phase interval counter) -> dac (EFC
actuation) -> servo (one controller interface: servo, servo_kernel; the servos null, pi, kalman,
kalman_adaptive, kalman_gated, kalman_huber, each one module; by name in registry) -> loop (closing the
loop over trials) -> states (free-run / acquiring / locked / holdover / recovery).
"""
