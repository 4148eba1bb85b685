"""Real data in: receiver logs (NMEA, UBX), RINEX, and phase/frequency records."""
