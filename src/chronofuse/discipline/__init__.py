"""GNSS-disciplined oscillator (the GNSSDO paper): one idea per module.

qualification (is a receiver's 1PPS usable) -> counter (multi-phase interval counter) -> dac (EFC
actuation) -> servo (one controller interface and its backends) -> loop (closing the loop over trials)
-> states (free-run / acquiring / locked / holdover / recovery).
"""
