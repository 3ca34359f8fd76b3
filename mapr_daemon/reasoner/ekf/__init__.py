"""The EKF: joint state and parameter estimation, and the adaptable reference model (paper II).

:mod:`.model` cuts bus-rate signals into blocks and holds the nonlinear mechanics with their
Jacobians; :mod:`.estimator` runs the filter over a BIT's record and keeps the reference the
estimates are compared with.
"""

from mapr_daemon.reasoner.ekf.estimator import Estimate, ParameterEstimator
from mapr_daemon.reasoner.ekf.model import NEEDED

__all__ = ["NEEDED", "Estimate", "ParameterEstimator"]
