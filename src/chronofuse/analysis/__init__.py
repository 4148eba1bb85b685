"""Analysis of clock data: stability statistics, time-error metrics and masks."""
