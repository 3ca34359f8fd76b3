"""RUL metrics (Saxena et al.), defined once for every bench and scoring tool.

Relative accuracy on RUL ``1 - |r* - r|/r*`` (on RUL, not on the time of the event, which
would flatter late predictions); alpha-lambda: at ``t_lambda = t0 + lambda*(EoL - t0)`` at
least ``beta`` of the RUL distribution within ``(1 +/- alpha) r*``; prognostic horizon: EoL
minus the first time from which every prediction stays within the alpha bounds.
"""

from __future__ import annotations

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError


def relative_accuracy(true_rul: float, est_rul: float) -> float:
    """RA on RUL: ``1 - |r* - r| / r*``."""
    if true_rul <= 0:
        raise ConfigError("true RUL must be > 0", field="rul")
    return 1.0 - abs(true_rul - est_rul) / true_rul


def alpha_lambda_pass(true_rul: float, draws: FloatArray, alpha: float = 0.2,
                      beta: float = 0.5) -> bool:
    """Whether at least ``beta`` of the RUL draws lie within ``(1 +/- alpha) r*``."""
    inside = (draws >= (1 - alpha) * true_rul) & (draws <= (1 + alpha) * true_rul)
    return bool(inside.mean() >= beta)


def prognostic_horizon(times: FloatArray, true_ruls: FloatArray, est_ruls: FloatArray,
                       eol: float, alpha: float = 0.2) -> float:
    """EoL minus the first time from which every point estimate stays within alpha bounds."""
    ok = np.abs(est_ruls - true_ruls) <= alpha * true_ruls
    for i in range(ok.size):
        if ok[i:].all():
            return float(eol - times[i])
    return 0.0
