"""Where a BIT departs from the unit's healthy prediction: the signals and the BIT phases that
carry most of the "no fault" residual.

What an event "anomaly, not explained by any known fault mode" read against the unit's
baseline names (docs/reasoner.md): a maintainer who is told that no known fault fits is told
where to look instead. The residual is the baseline reading's "no fault" residual, each signal
in its healthy held-out spread (:mod:`~mapr_daemon.reasoner.commissioning.severity`), so the
shares compare like with like: a share is that signal's (or that stretch of the BIT's) part of
the residual's total square.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray

PHASE_S = 0.1
"""Length of the BIT stretches the departure is apportioned to (100 ms: a BIT's moves and
holds last a few hundred)."""
TOP = 3
"""Signals and stretches named, largest first."""


def departures(z: FloatArray, signals: Sequence[str], decimate: int,
               sample_rate_hz: float) -> dict[str, Any]:
    """The ``TOP`` signals and ``PHASE_S`` stretches (ms from the BIT's start) of ``z``
    (``(K, T)``, one row per signal in ``signals``, ``decimate``-sample means) with the
    largest shares of its total square."""
    energy = np.asarray(z, dtype=np.float64) ** 2
    total = max(float(energy.sum()), 1e-12)
    by_signal = energy.sum(axis=1) / total
    dt_ms = 1000.0 * decimate / sample_rate_hz
    per = max(1, round(PHASE_S * 1000.0 / dt_ms))
    t = energy.shape[1]
    starts = np.arange(0, t, per)
    by_phase = np.add.reduceat(energy.sum(axis=0), starts) / total
    return {
        "signals": [{"signal": signals[k], "share": round(float(by_signal[k]), 3)}
                    for k in np.argsort(-by_signal)[:TOP]],
        "phases_ms": [{"from": round(float(starts[j]) * dt_ms, 1),
                       "to": round(float(min(starts[j] + per, t)) * dt_ms, 1),
                       "share": round(float(by_phase[j]), 3)}
                      for j in np.argsort(-by_phase)[:TOP]],
    }
