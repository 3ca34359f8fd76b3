"""Diagnosis: is a BIT abnormal, which fault, how severe — the paper's method and ours.

Reads as the step it is, bottom up: the window features around the BIT profile's corners
(:mod:`.features`, phase A's high side by commutation sector in :mod:`.sector`); the healthy
actuator's model at the run's flight condition (:mod:`.healthy_model`); fault signatures in its
whitened subspace (:mod:`.fault_models`), the paper's fault curves (:mod:`.curves`), the matched
filter for the weakest fault (:mod:`.matched_filter`) and the anomaly threshold for a stated
false-alarm rate (:mod:`.false_alarm`); the dictionary file that holds them
(:mod:`.dictionary`); the decision (:mod:`.classifier`); the replaceable parts and what the bus
cannot tell apart within one (:mod:`.parts`). :mod:`.curve_plots` draws the curves.
"""

from mapr_daemon.reasoner.diagnosis.classifier import Decision, decide
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.diagnosis.features import derived_signals, feature_matrix
from mapr_daemon.reasoner.diagnosis.healthy_model import HealthyModel, supply_floor_v
from mapr_daemon.reasoner.diagnosis.parts import COMPONENTS, PART_OF

__all__ = [
    "COMPONENTS", "PART_OF", "Decision", "Dictionary", "DictionarySpec", "HealthyModel",
    "decide", "derived_signals", "feature_matrix", "supply_floor_v",
]
