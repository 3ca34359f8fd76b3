"""Prognosis: how worn each part is, where its trend is going, and how sure that is.

Per BIT, one degradation estimate per aging kind (:mod:`.wear_estimators`) with its measured
noise (:mod:`.wear_noise`); across flights, the aging-shape trend with the fleet prior
(:mod:`.trend`) gives a RUL (:mod:`.rul`); :mod:`.assessment` reads an actuator's BIT history as
SoH, the leading mode and its RUL; :mod:`.soh` is the state-of-health formula against the
failure thresholds. :mod:`.prognostic_model` is the file that holds an actuator type's
estimators, noise and priors (built by :mod:`mapr_daemon.reasoner.training.prognosis_build`).
"""

from mapr_daemon.findings import Health
from mapr_daemon.reasoner.prognosis.assessment import INTERVAL, assess
from mapr_daemon.reasoner.prognosis.prognostic_model import AGING_KINDS, PrognosticModel
from mapr_daemon.reasoner.prognosis.rul import RulEstimate

__all__ = ["AGING_KINDS", "INTERVAL", "Health", "PrognosticModel", "RulEstimate", "assess"]
