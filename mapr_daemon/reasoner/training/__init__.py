"""Training: what the reasoner is built from, and how its RUL is scored.

Batched BIT runs of the plant (:mod:`.corpus`, on worker threads: :mod:`.workers`); the fault
dictionary's build and calibration (:mod:`.dictionary_build`); the prognostic model's build
(:mod:`.prognosis_build`); RUL scored along run-to-failure trajectories (:mod:`.rul_scoring`)
with the metrics defined once (:mod:`.rul_metrics`).
"""

from mapr_daemon.reasoner.training.corpus import BitRuns, Runs, simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import build
from mapr_daemon.reasoner.training.prognosis_build import BuildSpec, build_prognostic_model
from mapr_daemon.reasoner.training.rul_metrics import alpha_lambda_pass, relative_accuracy

__all__ = [
    "BitRuns", "BuildSpec", "Runs", "alpha_lambda_pass", "build", "build_prognostic_model",
    "relative_accuracy", "simulate_bit",
]
