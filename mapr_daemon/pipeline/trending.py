"""Flights and each actuator's trend, after the reasoner: the last step before the catalog.

The reasoner reads each BIT on its own (:class:`~.pipeline.Pipeline`). What a BIT means for
the actuator's life depends on the ones before it, so this step keeps, per actuator, its BIT
history (flight number and per-kind degradation estimates; reloaded from the catalog at
start, so a restart or the next replay continues the trend) and refits the trend after each
BIT (:func:`~mapr_daemon.reasoner.prognosis.assessment.assess`): SoH, the leading fault mode, RUL
with a
90 % interval in flights and in flight hours. The event of an anomalous BIT carries the
same SoH and RUL.

**Flights.** An aircraft's flights (:class:`FlightLog`) are told from the actuator traffic:
traffic that resumes after ``aircraft.flight_gap_s`` starts the next flight, and a flight's
hours are the span of its traffic. A replay or a fleet run that knows the flight (its file
name, its TMATS) *declares* it instead (:meth:`FlightLog.declare`): the whole recording is
that flight, of the declared hours (else its traffic's span). Flight hours at a BIT count
flights never seen (a fleet archive may hold only the BIT flights) at the mean of those seen;
RUL in hours is RUL in flights times that mean.

**In-flight estimates.** Each flight's in-flight row (:mod:`.inflight`) joins its actuator's
history as it ends; the RUL of a kind the tracker resolves (friction) fuses them with the
BITs (:mod:`mapr_daemon.reasoner.prognosis.fusion`), each with its own noise.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

from mapr_daemon.catalog import BitOutcome, Event
from mapr_daemon.catalog.model import BitRecord, Flight, InflightEstimate
from mapr_daemon.findings import Health
from mapr_daemon.reasoner.prognosis.assessment import INTERVAL, assess
from mapr_daemon.reasoner.prognosis.fusion import observation
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

NS_PER_HOUR = 3_600_000_000_000


@dataclasses.dataclass
class _Flight:
    number: int
    start_ns: int | None
    end_ns: int | None
    declared_hours: float | None = None
    source: str = "bus"

    @property
    def hours(self) -> float:
        if self.declared_hours is not None:
            return self.declared_hours
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return max(self.end_ns - self.start_ns, 0) / NS_PER_HOUR


class FlightLog:
    """One aircraft's flights: counted from its traffic, or declared."""

    def __init__(self, tail: str, gap_s: float, known: Sequence[Flight] = ()) -> None:
        self.tail = tail
        self.gap_ns = int(gap_s * 1e9)
        self.flights: dict[int, _Flight] = {
            f.flight: _Flight(f.flight, f.start_ns, f.end_ns,
                              f.hours if f.source == "declared" else None, f.source)
            for f in known}
        self.current: _Flight | None = None
        self.declared = False
        self.changed: set[int] = set()

    def declare(self, number: int, hours: float | None = None) -> None:
        """All traffic from now on is flight ``number`` (of ``hours``, else its span)."""
        flight = self.flights.get(number) or _Flight(number, None, None)
        flight.declared_hours, flight.source = hours, "declared"
        self.flights[number] = self.current = flight
        self.declared = True
        self.changed.add(number)

    def observe(self, t_ns: int) -> None:
        """Actuator traffic at ``t_ns`` (epoch ns)."""
        cur = self.current
        if cur is None and not self.declared and self.flights:
            last = self.flights[max(self.flights)]
            if last.end_ns is not None and 0 <= t_ns - last.end_ns < self.gap_ns:
                cur = self.current = last   # the daemon restarted within the flight
        if cur is not None and not self.declared and cur.end_ns is not None \
                and t_ns - cur.end_ns >= self.gap_ns:
            cur = None
        if cur is None:
            number = max(self.flights, default=0) + 1
            cur = self.current = self.flights[number] = _Flight(number, t_ns, t_ns)
        cur.start_ns = t_ns if cur.start_ns is None else min(cur.start_ns, t_ns)
        cur.end_ns = t_ns if cur.end_ns is None else max(cur.end_ns, t_ns)
        self.changed.add(cur.number)

    @property
    def number(self) -> int | None:
        return None if self.current is None else self.current.number

    def mean_hours(self) -> float | None:
        """Mean hours of the flights with a known length."""
        known = [f.hours for f in self.flights.values() if f.hours > 0]
        return sum(known) / len(known) if known else None

    def hours_at(self, t_ns: int | None) -> float | None:
        """Flight hours at ``t_ns`` in the current flight (flights not seen at the mean)."""
        cur = self.current
        mean = self.mean_hours()
        if cur is None:
            return None
        before = 0.0
        for n in range(1, cur.number):
            f = self.flights.get(n)
            if f is not None and f.hours > 0:
                before += f.hours
            elif mean is not None:
                before += mean
        into = 0.0
        if cur.start_ns is not None and t_ns is not None:
            into = max(t_ns - cur.start_ns, 0) / NS_PER_HOUR
        if cur.declared_hours is not None:
            into = min(into, cur.declared_hours)
        return before + into

    def pop_changed(self) -> list[Flight]:
        """The flights changed since the last call, for the catalog."""
        out = [Flight(self.tail, n, f.start_ns, f.end_ns, f.hours, f.source)
               for n in sorted(self.changed) if (f := self.flights[n])]
        self.changed = set()
        return out


@dataclasses.dataclass
class AssetHistory:
    """One actuator's BIT history, as the trend reads it."""

    flights: list[float] = dataclasses.field(default_factory=list)
    wear: list[Mapping[str, float]] = dataclasses.field(default_factory=list)
    conditions: list[Mapping[str, float] | None] = dataclasses.field(default_factory=list)
    """Each BIT's flight condition (None where not stored)."""
    sources: list[Mapping[str, Mapping[str, Any]] | None] = dataclasses.field(
        default_factory=list)
    """Per BIT, which path read each kind's wear (None where not stored: taken as the path
    the actuator has now; :mod:`~mapr_daemon.reasoner.prognosis.wear_paths`)."""
    inflight: dict[str, dict[int, tuple[float, float, float, float]]] = dataclasses.field(
        default_factory=dict)
    """Per aging kind, per flight its in-flight observation ``(flight, h, sd_flight,
    sd_baseline)``
    (:func:`~mapr_daemon.reasoner.prognosis.fusion.observation`; a flight stored again
    replaces its own)."""

    def add_inflight(self, row: InflightEstimate) -> None:
        """A flight's in-flight row: the parameters that trend an aging kind."""
        if row.flight is None:
            return
        for name, p in row.parameters.items():
            obs = observation(name, p)
            if obs is not None:
                kind, h, sd, common = obs
                self.inflight.setdefault(kind, {})[row.flight] = (float(row.flight), h, sd,
                                                                  common)

    def observations(self) -> dict[str, list[tuple[float, float, float, float]]]:
        return {k: [v[f] for f in sorted(v)] for k, v in self.inflight.items()}

    def add(self, flight: float, wear: Mapping[str, float],
            conditions: Mapping[str, float] | None,
            source: Mapping[str, Mapping[str, Any]] | None = None) -> None:
        """One more BIT; its conditions and wear sources stay aligned with the flights (a
        history loaded without them is padded with None)."""
        self.conditions.extend([None] * (len(self.flights) - len(self.conditions)))
        self.sources.extend([None] * (len(self.flights) - len(self.sources)))
        self.flights.append(float(flight))
        self.wear.append(dict(wear))
        self.conditions.append(dict(conditions) if conditions else None)
        self.sources.append({k: dict(v) for k, v in source.items()} if source else None)


def history_from_bits(bits: Sequence[BitRecord],
                      inflight: Sequence[InflightEstimate] = ()) -> dict[str, AssetHistory]:
    """Each actuator's trend history from its stored BITs (oldest first): the BITs with a
    flight and estimates, with their flight conditions and the path that read each estimate
    where stored; and its flights' in-flight rows."""
    history: dict[str, AssetHistory] = {}
    for b in bits:
        if b.flight is not None and b.wear:
            history.setdefault(b.asset, AssetHistory()).add(b.flight, b.wear, b.conditions,
                                                             b.wear_source)
    for r in inflight:
        history.setdefault(r.asset, AssetHistory()).add_inflight(r)
    return history


class Trending:
    """Flights of one aircraft and the trend of each of its actuators."""

    def __init__(self, tail: str, flight_gap_s: float,
                 models: Mapping[str, PrognosticModel | None],
                 history: Mapping[str, AssetHistory] | None = None,
                 flights: Sequence[Flight] = ()) -> None:
        self.tail = tail
        self.models = dict(models)
        self.history = {a: AssetHistory() for a in self.models}
        for asset, h in (history or {}).items():
            if asset in self.history:
                self.history[asset] = h
        self.log = FlightLog(tail, flight_gap_s, flights)

    def observe(self, t_ns: int) -> None:
        """The actuators' traffic was on the bus at ``t_ns`` (epoch ns)."""
        self.log.observe(t_ns)

    def add_inflight(self, rows: Sequence[InflightEstimate]) -> None:
        """Flights' in-flight rows: the next BIT's RUL fuses them (:mod:`.inflight`)."""
        for r in rows:
            if r.asset in self.history:
                self.history[r.asset].add_inflight(r)

    def annotate_batch(self, outcomes: Sequence[BitOutcome], traffic_end_ns: int | None
                       ) -> list[BitOutcome]:
        """The BITs of one batch of traffic, annotated (:meth:`annotate`), then the batch's
        last actuator traffic at ``traffic_end_ns`` observed (None: none in the batch).

        Each BIT is observed at its own time before it is annotated (a BIT is the actuator's
        traffic), so a gap long enough to start a flight inside a batch puts the BITs before
        it in the flight they were flown in, not the next one, whatever the batch's length.
        """
        out = []
        for outcome in outcomes:
            self.log.observe(outcome.t_ns)
            out += self.annotate([outcome])
        if traffic_end_ns is not None:
            self.log.observe(traffic_end_ns)
        return out

    def annotate(self, outcomes: Sequence[BitOutcome]) -> list[BitOutcome]:
        """Each BIT with its flight and the actuator's health after it (its event too)."""
        out = []
        for o in outcomes:
            if self.log.current is None:
                self.log.observe(o.t_ns)
            flight = self.log.number
            hours = self.log.hours_at(o.t_ns)
            health = self._health(o, flight)
            event = o.event
            if event is not None:
                event = _with_health(event, health)
            out.append(dataclasses.replace(o, tail=self.tail, flight=flight,
                                           flight_hours=hours, health=health, event=event))
        return out

    def _health(self, o: BitOutcome, flight: int | None) -> Health | None:
        model = self.models.get(o.asset)
        if model is None:
            return Health(None, note="no prognostic model configured for this actuator "
                                     "(assets[].prognosis): no SoH trend or RUL")
        if not o.wear or flight is None:
            return Health(None, note="this BIT gave no degradation estimates")
        hist = self.history.setdefault(o.asset, AssetHistory())
        hist.add(flight, o.wear, o.conditions, o.wear_source)
        fault = None if o.event is None else o.event.fault
        h = assess(model, hist.flights, hist.wear, diagnosed=fault, seed=len(hist.flights),
                   conditions=hist.conditions, also=_also(o.event),
                   inflight=hist.observations(), sources=hist.sources)
        return h.with_hours(self.log.mean_hours(), INTERVAL)


def _also(event: Event | None) -> tuple[str, ...]:
    """The other fault of a compound diagnosis (its evidence's ``compound``), else none."""
    if event is None:
        return ()
    found = event.evidence.get("compound")
    if not isinstance(found, Mapping):
        return ()
    faults = [str(m.get("fault")) for m in found.get("faults", ()) if isinstance(m, Mapping)]
    return tuple(f for f in faults if f != event.fault)


def _with_health(event: Event, health: Health | None) -> Event:
    if health is None or health.soh is None:
        return event
    def fin(v: float | None) -> float | None:
        return v if v is None or math.isfinite(v) else None
    return dataclasses.replace(event, soh=health.soh, rul=fin(health.rul),
                               rul_low=fin(health.rul_low), rul_high=fin(health.rul_high),
                               rul_unit="flights" if health.rul is not None else None)
