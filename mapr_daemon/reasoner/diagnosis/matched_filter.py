"""A matched filter for the weakest fault: one statistic, its own threshold.

The likelihood ratio reads a run on the 32 coordinates of the fault subspace, against a
threshold set by the healthy runs' largest explained energy over every template. A weak fault
that moves a few cells by a few healthy spreads — the inverter's phase-A high-side Ron, mostly
seen by the sector-resolved loop resistance (:mod:`~mapr_daemon.reasoner.diagnosis.sector`) and the
phase-A current's spread — stays under it. Its matched filter instead projects the run's
standardized cells (deviation from the healthy prediction, in healthy spreads) on one
direction ``w = S^-1 mu``: ``mu`` the fault's signature per unit severity (a line through
the origin fitted to the dictionary's runs at small severities), ``S`` the healthy cells'
covariance shrunk towards a multiple of the identity (:data:`SHRINKAGE`; with half as many
cells as healthy runs the unshrunk inverse fits their noise). One number per run, whose
healthy law is close to normal;
its one-sided threshold comes from the calibration runs like the others'
(:func:`~mapr_daemon.reasoner.diagnosis.false_alarm.calibrate_gaussian`), so the shrinkage changes
the
filter's power, never its false-alarm rate.
"""

from __future__ import annotations

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError

KIND = "inverter_ron_a_high"
"""The fault the filter is matched to (an alarm from it alone names this fault)."""
SHRINKAGE = 0.2
"""Weight of the identity in the filter's covariance, chosen on a validation set of runs
disjoint from the dictionary and from the accuracy bench (own seeds, 80 phase-A Ron runs at
20-100 % of the range, 300 healthy): 0.1, 0.2 and 0.3 detected 79, 79 and 78 of the 80 with
the other statistics, with no healthy alarm; the filter's power, not its false-alarm rate,
depends on it."""
MAX_SEVERITY = 0.5
"""The signature is averaged over the dictionary's runs up to this severity (where the filter
matters; a gross fault is the likelihood ratio's)."""


def fit(z_healthy: FloatArray, z_fault: FloatArray, severities: FloatArray,
        shrinkage: float = SHRINKAGE) -> FloatArray:
    """The filter's weights ``(D,)`` from healthy runs' standardized cells ``(n, D)`` and the
    fault's runs' ``(m, D)`` at ``severities`` (fractions of its range)."""
    keep = (severities > 0.0) & (severities <= MAX_SEVERITY)
    if not keep.any() or z_healthy.shape[0] < 2:
        raise ConfigError(f"the matched filter needs healthy runs and {KIND} runs at "
                          f"severities up to {MAX_SEVERITY}", field="kinds")
    # the signature per unit severity: least squares through the origin (z = s * mu + noise),
    # so a run at a small severity does not bring its noise divided by that severity
    sev = severities[keep]
    mu = sev @ z_fault[keep] / float(sev @ sev)
    s = z_healthy.T @ z_healthy / z_healthy.shape[0]
    p = s.shape[0]
    cov = (1.0 - shrinkage) * s + shrinkage * float(np.trace(s)) / p * np.eye(p)
    w: FloatArray = np.linalg.solve(cov, mu)
    return w


def statistic(weights: FloatArray, z: FloatArray, mean: float, sd: float) -> float:
    """The run's filter output in its healthy spreads (``z`` its standardized cells)."""
    return float((z @ weights - mean) / sd)
