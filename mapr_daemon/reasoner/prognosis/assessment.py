"""An actuator's state of health and remaining useful life from its BIT history.

After each BIT the actuator's history — per BIT its flight number and the degradation
estimate of every aging kind
(:meth:`~mapr_daemon.reasoner.prognosis.prognostic_model.PrognosticModel.estimates`) — is read as:

* **which part is wearing**: a kind is *evidenced* when the mean of its last
  :data:`RECENT` readings, each weighted by the inverse of its variance (its measured noise,
  :class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise`, at that BIT's stored flight condition:
  a BIT flown near
  the bus's low limit weighs little), lies more than :data:`EVIDENCE_Z` standard errors above
  healthy (:data:`UNSEEN_Z` while the classifier names no fault at this BIT and another
  part's kind also reads above its scatter), or when the
  classifier names it at this BIT. The **leading mode** is the kind
  the classifier names, if evidenced (the estimators of two kinds can both respond to one
  fault; the classifier is what tells kinds apart), else the evidenced kind with the
  shortest median RUL;
* **a part's wear, not each estimator's**: only a kind whose own evidence says so is
  reported wearing (``evidenced``). The other kinds of the leading kind's part (ESR and
  capacitance are one capacitor) read as that part's wear, and while the classifier names
  faults at this BIT, kinds of parts it did not name read as the named fault's response
  (``read_as`` in their row): an estimator answers a little to every part's change, and the
  classifier, which weighs the whole record against single faults and pairs, decided which
  parts are faulted. Measured on single-fault units of each kind (the demo's models):
  an ESR fault read as capacitance wear at z 3.7-8.5, a friction fault as ESR wear at z
  3.9-7.9;
* **SoH** ``= 1 - h`` of the leading mode, clipped to [0, 1]: 1.0 as commissioned, 0.0 at
  that mode's failure threshold (:data:`~mapr_daemon.ema.degradation.FAILURE`, e.g. ESR at
  twice nominal), ``h`` that weighted mean of its last :data:`RECENT` readings. With no
  evidenced kind SoH is 1.0 and there is no RUL: nothing is wearing measurably;
* **RUL** of the leading mode in flights, the median and a 90 % interval (5 % and 95 %
  points of the trend's draws, :func:`~.trend.fit_rul`: the kind's aging shape with the
  fleet prior; friction's per-flight in-flight estimates fused in, :mod:`.fusion`); in
  flight hours by the actuator's mean flight length so far. ``inf`` where
  the trend does not reach the threshold within its horizon (:data:`HORIZON` flights, or
  :data:`HORIZON_LIVES` times the part's expected life if longer); 0 once the mode's
  degradation is past its threshold. A trend needs BITs on three flights or more.
* **per mode** (:attr:`Health.modes`), every trended kind states its own RUL once there are
  BITs on three flights, evidenced or not: for a kind whose readings are still within their
  healthy scatter it is the same trend, where the readings say "little wear so far" and the
  fleet prior says how parts of that kind age from there (the prior is learned from parts
  that do age; a part that never ages is outside it). Only an evidenced kind can lead, so
  the headline RUL, SoH and episodes are unchanged by it; withholding the RUL until a kind
  is evidenced left a fifth of a simulated fleet's BITs (from a quarter of life on) with no
  statement at all, while a capacitor's or a switch's early wear was still inside one
  reading's scatter.

A shorted or open switch (a terminal fault) is SoH 0 and RUL 0 at once.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.findings import Health
from mapr_daemon.reasoner.diagnosis.parts import PART_OF
from mapr_daemon.reasoner.prognosis import fusion, trend
from mapr_daemon.reasoner.prognosis.rul import RulEstimate
from mapr_daemon.reasoner.prognosis.wear_noise import scaled_rows
from mapr_daemon.reasoner.prognosis.wear_paths import PathNoise, Source

if TYPE_CHECKING:
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

RECENT = 3
"""BITs whose mean is the current degradation and its evidence."""
EVIDENCE_Z = 3.0
"""Standard errors above healthy that make a kind's wear evidenced."""
UNSEEN_Z = 2.0 * EVIDENCE_Z
"""The same while the classifier names no fault at this BIT and a kind of another part also
reads above :data:`SCATTER_Z`: an estimator answers a little to every part's change, and
before the classifier sees a fault nothing else says which part changed (measured on
single-fault units: a friction unit's capacitance estimate at z 3.1-4.0 while its friction
was at 2.3-2.8)."""
SCATTER_Z = 2.0
"""Standard errors above healthy beyond which a reading is more than its scatter."""
HORIZON = 2000.0
"""Flights the trend is followed to at least; a RUL beyond the horizon is ``inf``."""
HORIZON_LIVES = 3.0
"""The horizon is at least this many times the prior's expected life (a part stated to live
5,000 flights is followed beyond 2,000)."""
INTERVAL = 0.90
"""Coverage of the stated RUL interval (its 5 % and 95 % points)."""
TERMINAL = ("short", "open")
FIRST_FLIGHT = 1.0
"""The number of a part's first flight. Flights are numbered from 1 (the daemon's flight log,
``mapr replay --flight``) and the BIT is flown at a flight's start, so at flight ``N``'s BIT
the part has flown ``N - 1`` flights: the age the trend's aging shapes count from (``h = 0``
at age 0). Counting from ``N`` put the part's new state one flight early and read every
RUL about a flight late (issue 28: a flight is 2 % of a 50-flight life, 8 % of its RUL at
three quarters of it)."""


def assess(model: PrognosticModel, flights: Sequence[float],
           estimates: Sequence[Mapping[str, float]], diagnosed: str | None = None,
           seed: int = 0, conditions: Sequence[Mapping[str, float] | None] = (),
           also: Sequence[str] = (),
           inflight: Mapping[str, Sequence[tuple[float, ...]]] | None = None,
           sources: Sequence[Mapping[str, Source] | None] = ()) -> Health:
    """Health after the last BIT of ``flights``/``estimates`` (oldest first); ``diagnosed``
    is the classifier's fault at that BIT (None when nominal), ``also`` the other fault of a
    compound diagnosis; ``conditions``: each BIT's
    flight condition
    (:meth:`~mapr_daemon.reasoner.prognosis.prognostic_model.PrognosticModel.bit_conditions`;
    missing or None
    where not stored); ``inflight``: per kind the flights' in-flight observations
    ``(flight, h, sd)`` or ``(flight, h, sd_flight, sd_baseline)`` the RUL fuses with the
    BITs (:mod:`.fusion`); ``sources``: per BIT, which path read each kind's estimate
    (:mod:`.wear_paths`; missing or None: the path ``model`` has now), by whose noise and
    offset it is weighed."""
    if diagnosed in TERMINAL:
        return Health(0.0, diagnosed, 0.0, 0.0, 0.0, note="terminal fault: the part has failed")
    if not flights:
        return Health(1.0, None, note="no BIT yet")
    fl = np.asarray(flights, dtype=np.float64)
    now = float(fl[-1])
    age = np.maximum(fl - FIRST_FLIGHT, 0.0)   # flights flown before each BIT
    cond = scaled_rows([model.scaled(conditions[i]) if i < len(conditions) else None
                        for i in range(fl.size)], fl.size)
    modes: dict[str, dict[str, Any]] = {}
    candidates: list[tuple[float, float, str, RulEstimate | None]] = []
    readings: dict[str, tuple[float, float, FloatArray, FloatArray]] = {}
    paths: dict[str, PathNoise] = {}
    per_bit = [sources[i] if i < len(sources) else None for i in range(fl.size)]
    for kind in model.kinds:
        est = np.array([e.get(kind, math.nan) for e in estimates], dtype=np.float64)
        keep = np.isfinite(est)
        if keep.any():
            paths[kind] = model.path_noise(kind, per_bit).take(keep)
            h, z = _reading(paths[kind], est[keep], cond[keep])
            readings[kind] = (h, z, est, keep)
    for kind, (h, z, est, keep) in readings.items():
        obs = (inflight or {}).get(kind, ())
        evidenced = kind == diagnosed or z > _bar(kind, diagnosed, readings)
        row: dict[str, Any] = {"h": round(h, 4), "z": round(z, 2), "evidenced": evidenced}
        rul = None
        if evidenced and h >= 1.0:   # past its failure threshold: failed now, nothing to fit
            rul = RulEstimate(0.0, 0.0, 0.0, np.zeros(1), horizon(model, kind))
            row.update(rul=0.0, low=0.0, high=0.0)
        elif np.unique(np.concatenate((fl[keep], [o[0] for o in obs]))).size >= 3:
            aged = [(max(o[0] - FIRST_FLIGHT, 0.0), *o[1:]) for o in obs]
            # a reading against the unit's baseline: its offset is the unit's, measured
            # (its path takes no fleet offset, PathNoise.own)
            rul = fusion.fit_rul_fused(age[keep], est[keep], now - FIRST_FLIGHT, kind,
                                       paths[kind], model.priors.get(kind), aged, seed=seed,
                                       horizon=horizon(model, kind), conditions=cond[keep])
            row.update(rul=_finite(rul.rul), low=_finite(rul.lower), high=_finite(rul.upper))
            share = trend.prior_share(model.priors.get(kind), kind, now - FIRST_FLIGHT, rul)
            if not math.isnan(share):
                row["prior_share"] = round(share, 2) if math.isfinite(share) else None
            if obs:
                row["inflight_flights"] = len(obs)
        modes[kind] = row
        if evidenced:
            candidates.append((math.inf if rul is None else rul.rul, -h, kind, rul))
    if not candidates:
        return Health(1.0, None, note="no part wears measurably: every trended part is within "
                                      "its healthy scatter", modes=modes)
    named_parts = {PART_OF.get(f, f) for f in (diagnosed, *also) if f is not None}
    if named_parts:   # the classifier saw the whole record: its parts are the wearing ones
        ours = [c for c in candidates if PART_OF.get(c[2]) in named_parts]
        candidates = ours or candidates
    named = [c for c in candidates if c[2] == diagnosed]   # the classifier tells kinds apart
    _, neg_h, kind, rul = named[0] if named else min(candidates, key=lambda c: (c[0], c[1]))
    _as_the_part(modes, kind, named_parts)
    soh = float(min(1.0, max(0.0, 1.0 + neg_h)))
    if rul is None:
        return Health(soh, kind, note="BITs on fewer than three flights: no trend yet",
                      modes=modes)
    leaning = _leans_on_prior(model, kind, modes[kind])
    if leaning is not None:
        return Health(soh, kind, note=leaning, modes=modes)
    return Health(soh, kind, rul.rul, rul.lower, rul.upper, modes=modes,
                  note=None if math.isfinite(rul.rul) else
                  f"the trend does not reach the failure threshold within {rul.horizon:g} "
                  "flights")


def _leans_on_prior(model: PrognosticModel, kind: str, row: Mapping[str, Any]) -> str | None:
    """Why the headline RUL of ``kind`` is withheld, or None: where nobody stated the part's
    life (:attr:`PrognosticModel.assumed_lives`) and the unit's readings have narrowed the
    prior's spread of it by less than :data:`~.trend.LEANS` allows (``prior_share``; None:
    the draws run past the horizon), the figure would be the aging model's assumed life, not
    this unit's trend. The mode's row keeps its figures. A RUL whose median is beyond the
    horizon (``rul`` None in the row: no degradation to trend yet, or wearing too slowly) is
    not the assumed life: it keeps its own note, as with a stated life."""
    prior = model.priors.get(kind)
    if prior is None or kind not in model.assumed_lives or "prior_share" not in row \
            or row.get("rul") is None:
        return None
    share = row["prior_share"]
    if share is not None and share <= trend.LEANS:
        return None
    spread = "beyond the horizon" if share is None else f"{100 * share:.0f} % of it"
    return (f"the {kind} trend has not yet narrowed the part's life (its interval spans "
            f"{spread}): the figure would be the data sheet's assumed life of about "
            f"{prior.life_flights(kind):.0f} flights, not this unit's (state "
            "assets[].expected_life_flights for the fleet, or wait for more BITs)")


def _reading(paths: PathNoise, est: FloatArray, cond: FloatArray) -> tuple[float, float]:
    """``(h, z)`` of one kind: the inverse-variance weighted mean of its last :data:`RECENT`
    readings (each calibrated and weighed by its path's noise), and that mean in standard
    errors above healthy."""
    last = paths.take(slice(-RECENT, None))
    recent = last.calibrate(est[-RECENT:], cond[-RECENT:])
    sd = last.h_sd(np.full(recent.size, max(float(np.mean(recent)), 0.0)), cond[-RECENT:])
    w = 1.0 / np.maximum(sd, 1e-9) ** 2   # a BIT flown where it reads poorly weighs little
    h = float(np.sum(w * recent) / np.sum(w))
    se = float(1.0 / np.sqrt(np.sum(w)))
    return h, h / max(se, 1e-9)   # finite: the catalog stores it as JSON


def _bar(kind: str, diagnosed: str | None, readings: Mapping[str, tuple[float, float, Any, Any]]
         ) -> float:
    """The z above which ``kind`` is evidenced: :data:`EVIDENCE_Z`, or :data:`UNSEEN_Z`
    while the classifier names no fault and a kind of another part also reads above its
    scatter (:data:`SCATTER_Z`): then the two estimators' readings cannot say which part
    changed (each answers a little to the other's part)."""
    if diagnosed is not None:
        return EVIDENCE_Z
    part = PART_OF.get(kind)
    others = any(z > SCATTER_Z for k, (_, z, _, _) in readings.items()
                 if k != kind and PART_OF.get(k) != part)
    return UNSEEN_Z if others else EVIDENCE_Z


def _as_the_part(modes: dict[str, dict[str, Any]], lead: str, named_parts: set[str]) -> None:
    """Only a mode whose own evidence says so is ``evidenced`` (wearing): the other modes of
    the leading mode's part read as that part's wear (their estimators respond to the same
    part's change: an ESR fault moves the capacitance estimate too), and while the
    classifier names faults at this BIT, modes of parts it did not name read as the named
    fault's response (an estimator answers a little to every part; the classifier, which
    weighs the whole record against single faults and pairs, decided that no other part is
    faulted). Each such row keeps its figures, is not ``evidenced``, and says ``read_as``
    (the leading mode) and, within the part, ``part``."""
    part = PART_OF.get(lead)
    for kind, row in modes.items():
        if kind == lead or not row["evidenced"]:
            continue
        if part is not None and PART_OF.get(kind) == part:
            row.update(evidenced=False, part=part, read_as=lead)
        elif named_parts and PART_OF.get(kind) not in named_parts:
            row.update(evidenced=False, read_as=lead)


def horizon(model: PrognosticModel, kind: str) -> float:
    """Flights the trend of ``kind`` is followed to: :data:`HORIZON`, or
    :data:`HORIZON_LIVES` expected lives of the part (its fleet prior's) if longer."""
    prior = model.priors.get(kind)
    return HORIZON if prior is None else max(HORIZON, HORIZON_LIVES * prior.life_flights(kind))


def _finite(v: float) -> float | None:
    return round(v, 2) if math.isfinite(v) else None
