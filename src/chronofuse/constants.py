"""Physical constants used across the package (SI)."""

#: Speed of light in vacuum, m/s (exact, SI definition; IS-GPS-200 uses the same value).
SPEED_OF_LIGHT_M_PER_S = 299_792_458.0
