"""A BIT's fault mode and severity read against the unit's own commissioned healthy behaviour.

The seed paper's premise is that degradation moves physical parameters. After commissioning
the unit's healthy behaviour is the identified model plus its learned discrepancy
(:mod:`~mapr_daemon.reasoner.commissioning.discrepancy`); a fault is what moves the record away
from it. Each hypothesis — a parametric mode of :data:`~mapr_daemon.ema.faults.PARAMETRIC` at
a severity, an open or shorted switch, or none — predicts the BIT as

    identified model with the fault seeded  +  the unit's discrepancy at the BIT's condition,

so the fault's departure, ``model(identified, fault) - model(identified)``, is taken from our
model around the unit's identified operating point and added to the unit's own healthy
prediction; what our model cannot express of the unit is not asked of the fault. The
hypotheses are scored by the mean square of record minus prediction, each signal in units of
its healthy held-out spread at that time of the profile (what model plus discrepancy left on
healthy BITs it was not learned on, never below the sensor noise), and the best wins (least
squares over the mode and its severity).

The severity of each parametric mode is found on a grid (:data:`GRID`, one batched plant call
for all modes and switches of one BIT), refined around the best grid point of the best mode
(a second call) and interpolated by a parabola through the three best points. Severity is
the fraction of the data sheet's Table 1 range (:func:`~mapr_daemon.ema.faults.at_severity`),
the scale the dictionary reports on.

With ``pairs`` > 0 the best pair of two parametric faults in different parts among the
``pairs`` best single modes is searched as well
(:func:`~mapr_daemon.reasoner.commissioning.pairs.search`) and carried in
:attr:`Reading.pair`; whether it is named is
:func:`~mapr_daemon.reasoner.commissioning.unit_decision.named_pair`'s rule.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import PARAMETRIC, SWITCHES, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord
from mapr_daemon.reasoner.commissioning.conduction import OpenSwitch, open_switch
from mapr_daemon.reasoner.commissioning.departures import departures
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy, correction_for
from mapr_daemon.reasoner.commissioning.flight import Flight, fly, noise_scale, recorded
from mapr_daemon.reasoner.commissioning.pairs import PairReading, search, vertex

GRID: tuple[float, ...] = (0.03, 0.08, 0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 0.75, 0.875, 1.0)
"""Severities tried first for every parametric mode (fractions of the Table 1 range)."""
TERMINAL = ("short", "open")
HEALTHY = "healthy"


@dataclasses.dataclass(frozen=True)
class Reading:
    """What one BIT says against the unit's baseline."""

    mode: str
    """The best hypothesis: a fault kind, or ``healthy``."""
    switch: str
    """The switch of a short or open; empty otherwise."""
    severity: float
    """Fraction of the data sheet's range (1.0 for short/open, 0.0 for healthy)."""
    cost: float
    """Mean square of the best hypothesis's residual, in healthy spreads."""
    healthy_cost: float
    """The same for "no fault": ``healthy_cost - cost`` is what the fault explains."""
    costs: dict[str, float]
    """Best cost per mode (``short``/``open`` over their switches)."""
    pair: PairReading | None = None
    """The best pair of two faults in different parts, when pairs were searched (whatever
    its cost: :func:`~mapr_daemon.reasoner.commissioning.unit_decision.named_pair` decides
    whether it is named)."""
    departures: dict[str, Any] | None = None
    """Where the "no fault" residual lies: the signals and BIT stretches with the largest
    shares (:func:`~mapr_daemon.reasoner.commissioning.departures.departures`); what an
    unexplained event names."""
    open_seen: OpenSwitch | None = None
    """The open switch the recorded phase currents show
    (:func:`~mapr_daemon.reasoner.commissioning.conduction.open_switch`); when set, the
    reading is that open switch (``mode``, ``switch`` and ``cost`` are its), whatever
    hypothesis the least squares preferred."""

    @property
    def least_cost(self) -> float:
        """The least cost of any single hypothesis flown (``cost`` unless the phase currents
        named the open switch): what the detector's ``explained`` statistic takes off."""
        if self.open_seen is None:
            return self.cost
        return min([self.cost, *self.costs.values()])


def weights(params: ActuatorParams, disc: Discrepancy | None, decimate: int) -> FloatArray:
    """(K, T) or (K, 1): what a residual is measured in: the unit's healthy held-out spread,
    never below the sensor noise (the noise alone without a discrepancy)."""
    floor = noise_scale(params, decimate)[:, None]
    if disc is None:
        return floor
    out: FloatArray = np.maximum(disc.healthy_spread(), floor)
    return out


def _parabola(s: FloatArray, c: FloatArray) -> float:
    """The minimum of the parabola through the three lowest-cost points, kept inside their
    span (the best point itself when they do not bracket a minimum)."""
    order = np.argsort(c)[:3]
    x, y = s[order], c[order]
    if len(x) < 3 or len(set(np.round(x, 12))) < 3:
        return float(x[0])
    return vertex(x, y)


def read(params: ActuatorParams, datasheet: ActuatorParams, disc: Discrepancy | None,
         bit: BitRecord, decimate: int, kinds: Sequence[str] = tuple(PARAMETRIC),
         terminal: bool = True, pairs: int = 0, data: FloatArray | None = None) -> Reading:
    """The mode and severity of ``bit`` against the unit's baseline: ``params`` (the
    identified actuator) plus ``disc`` (None: the model alone). ``datasheet`` gives the
    faults' ranges. ``kinds``: the parametric modes considered; ``terminal``: whether
    shorted and open switches are; ``pairs``: how many of the best single modes' pairs are
    searched (0: none). ``data``: the record's fit signals ``(K, T)`` to read instead of
    ``bit``'s own (``bit`` still gives the command and the condition): a recorded BIT with a
    fault's departure added, as the detector's calibration makes
    (:func:`~mapr_daemon.reasoner.commissioning.detector.single_allowance`)."""
    if data is None:
        data = recorded([bit], decimate)[0]
    corr = correction_for(disc, params, [bit])[0] if disc is not None else 0.0
    w = weights(params, disc, decimate)

    no_fault: list[FloatArray] = []

    def costs(faults: list[FaultSet]) -> FloatArray:
        y = fly(params, [Flight(bit, f) for f in faults], decimate)
        z = (data - y - corr) / w
        if not no_fault:  # the first call's first hypothesis is "no fault"
            no_fault.append(z[0])
        out: FloatArray = np.mean(z**2, axis=(1, 2))
        return out

    hyps: list[tuple[str, str, float]] = [(HEALTHY, "", 0.0)]
    hyps += [(k, "", s) for k in kinds for s in GRID]
    if terminal:
        hyps += [(k, sw, 1.0) for k in TERMINAL for sw in SWITCHES]
    c = costs([_faults(datasheet, h) for h in hyps])
    best_mode: dict[str, float] = {}
    for (mode, _, _), v in zip(hyps, c, strict=True):
        best_mode[mode] = min(best_mode.get(mode, np.inf), float(v))
    i = int(np.argmin(c))
    mode, switch, severity = hyps[i]
    cost = float(c[i])
    if mode in kinds:
        # refine: two points each side of the best grid point, then a parabola
        j = GRID.index(severity)
        lo = GRID[j - 1] if j > 0 else 0.0
        hi = GRID[j + 1] if j + 1 < len(GRID) else 1.0
        thirds = np.array([1.0, 2.0]) / 3.0
        extra = sorted({float(x) for x in np.r_[severity + (lo - severity) * thirds,
                                                 severity + (hi - severity) * thirds]}
                       - {severity})
        c2 = costs([_faults(datasheet, (mode, "", s)) for s in extra])
        s_all = np.array([h[2] for h in hyps if h[0] == mode] + extra)
        c_all = np.array([float(v) for h, v in zip(hyps, c, strict=True) if h[0] == mode]
                         + list(c2))
        severity = _parabola(s_all, c_all)
        cost = min(cost, float(np.min(c2)))
        best_mode[mode] = cost
    pair = search(costs, datasheet, best_mode, kinds, pairs) if pairs > 0 else None
    where = departures(no_fault[0], FIT_SIGNALS, decimate, params.sensors.sample_rate_hz)
    seen = open_switch(params, bit.channels) if terminal else None
    if seen is not None:
        # the bridge says which switch is open; the motion that open left on this unit is not
        # asked of the model (conduction module docstring)
        mode, switch, severity = "open", seen.switch, 1.0
        cost = float(c[hyps.index(("open", seen.switch, 1.0))])
    return Reading(mode, switch, float(severity), cost, float(c[0]), best_mode, pair, where,
                   seen)


def _faults(datasheet: ActuatorParams, hyp: tuple[str, str, float]) -> FaultSet:
    mode, switch, severity = hyp
    if mode == HEALTHY:
        return FaultSet()
    if mode in TERMINAL:
        return FaultSet.of([Fault(mode, switch=switch)])
    return FaultSet.of([at_severity(datasheet, mode, severity)])
