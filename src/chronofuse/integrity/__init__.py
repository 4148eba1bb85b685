"""Receiver clock-bias integrity: anomaly detection and faulty-channel identification."""
