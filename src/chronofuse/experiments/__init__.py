"""Scenarios, the main job, Monte Carlo runs and the reproductions of the source papers."""
