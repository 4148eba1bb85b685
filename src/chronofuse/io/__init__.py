"""Real data in: receiver logs (NMEA, UBX), RINEX, and phase/frequency records, each read into the one epoch
record (:class:`chronofuse.record.EpochRecord`, re-exported here)."""

from chronofuse.record import EpochRecord, Provenance

__all__ = ["EpochRecord", "Provenance"]
