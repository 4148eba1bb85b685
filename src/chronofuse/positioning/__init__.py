"""GNSS/INS positioning: strapdown inertial navigation, GNSS/INS filters and smoothing."""

#: The satellite systems a simulated drive uses, by name (:mod:`chronofuse.positioning.scenario`). The scenario's
#: constants live here, so that ``chronofuse position --help`` names them without importing the simulation.
SYSTEMS = {"gps": ("gps",), "gps+bds": ("gps", "bds")}
#: The scenarios' limit on a road vehicle's speed (m/s).
MAX_SPEED_M_PER_S = 70.0
