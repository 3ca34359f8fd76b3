"""Commissioning: the model fitted to the actuator the bus carries, and the dictionary made its own.

The healthy BIT records it works from (:mod:`.bits`); what a data sheet may change and by how
much (:mod:`.prior`); the least-squares problem (:mod:`.problem`) and the identification
(:mod:`.identify`); what the identified model still misses, learned on the unit's healthy BITs
(:mod:`.discrepancy`, the model flown through records by :mod:`.flight`); a BIT's fault mode
and severity read against that commissioned baseline (:mod:`.severity`, loaded from a
commissioning folder by :mod:`.baseline`); the dictionary's healthy model and thresholds
calibrated to the unit (:mod:`.calibrate`); the record of what was done (:mod:`.record`).
"""

from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.bits import BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.calibrate import MIN_BITS, calibrate_unit
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy, learn_unit
from mapr_daemon.reasoner.commissioning.identify import Identification, identify
from mapr_daemon.reasoner.commissioning.record import CommissioningRecord, read_record

__all__ = [
    "MIN_BITS", "Baseline", "BitRecord", "CommissioningRecord", "Discrepancy", "Identification",
    "calibrate_unit", "from_runs", "identify", "learn_unit", "read_record",
]
