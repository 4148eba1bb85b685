"""Live multi-receiver monitor: per-second decisions on real receivers, integrity alarms, a durable log."""
