"""Physical constants used across the package (SI)."""

#: Speed of light in vacuum, m/s (exact, SI definition; IS-GPS-200 uses the same value).
SPEED_OF_LIGHT_M_PER_S = 299_792_458.0

#: Earth's rotation rate, rad/s (WGS 84, NIMA TR8350.2 table 3.1; IS-GPS-200 uses the same value).
EARTH_ROTATION_RAD_PER_S = 7.2921151467e-5
