"""The model-based reasoner: a BIT's signals in, a diagnosis out; SoH and RUL across flights.

Sub-packages, in the order of the pipeline (each imports only those before it):

* :mod:`~mapr_daemon.reasoner.diagnosis` — window features, the healthy model, fault models
  and curves, the classifier, the dictionary file, the replaceable parts;
* :mod:`~mapr_daemon.reasoner.ekf` — joint state and parameter estimation (the EKF);
* :mod:`~mapr_daemon.reasoner.prognosis` — per-BIT wear estimates, their noise, the trend,
  SoH and RUL, the prognostic-model file;
* :mod:`~mapr_daemon.reasoner.training` — dictionary and prognostic-model builds from the
  plant, and RUL scoring;
* :mod:`~mapr_daemon.reasoner.commissioning` — identification of a unit and calibration of a
  dictionary to it.

:class:`Reasoner` (:mod:`.reasoner`) is the face the daemon, replay, fleet and the CLI use::

    reasoner = Reasoner(Dictionary.load("dictionary.npz"), load_actuator("aileron.yaml"))
    diagnosis = reasoner.diagnose(channels, command_deg, dynamic_pressure_pa)

Names are loaded on first use, so importing one sub-package does not pull in the others.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mapr_daemon.findings import Health
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.prognosis.assessment import assess
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
    from mapr_daemon.reasoner.reasoner import Reasoner

_HOMES = {
    "Reasoner": "mapr_daemon.reasoner.reasoner",
    "Dictionary": "mapr_daemon.reasoner.diagnosis.dictionary",
    "PrognosticModel": "mapr_daemon.reasoner.prognosis.prognostic_model",
    "Health": "mapr_daemon.findings",
    "assess": "mapr_daemon.reasoner.prognosis.assessment",
}


def __getattr__(name: str) -> Any:
    """Load a public name from its module on first use (PEP 562)."""
    if name in _HOMES:
        return getattr(importlib.import_module(_HOMES[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["Dictionary", "Health", "PrognosticModel", "Reasoner", "assess"]
