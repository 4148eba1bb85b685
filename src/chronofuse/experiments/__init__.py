"""Scenarios, the main job, Monte Carlo runs and the reproductions of the source papers."""

#: Root seed of every simulation of the validation suite (:mod:`chronofuse.experiments.validation`, one
#: SeedSequence per experiment). Here, so that ``chronofuse validate --help`` shows it without importing the suite.
VALIDATION_SEED = 20261124
