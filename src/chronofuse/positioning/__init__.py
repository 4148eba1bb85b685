"""GNSS/INS positioning: strapdown inertial navigation, GNSS/INS filters and smoothing."""
