"""The records the fault catalog stores, as plain typed values.

The daemon builds :class:`Event` values from the reasoner's decisions and hands them to the
writer in batches; the reader gives the same class back with ``id`` and ``session_id`` filled
in. Times are Unix epoch nanoseconds (UTC) everywhere, so a row sorts and compares as one
integer and no time zone is ever stored.

Severity has two faces, both kept: ``severity`` is the fraction of the fault's range
(0 nominal, 1 the end of the paper's Table 1 range; ``None`` for a terminal fault such as a
shorted or open switch, which the filters count as 1.0) so one ``--min-severity`` means the
same for every fault mode; ``severity_value`` with ``severity_unit`` is the faulted parameter
in physical units (``0.45`` ``ohm``) for the maintainer.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from mapr_daemon.findings import Diagnosis, Health


def display_name(tail: str, asset: str) -> str:
    """How an actuator is named to a maintainer: ``TAIL/ASSET`` (just the asset when no tail
    is known, or when it already carries its tail, as a fleet run's ``N101/EMA1`` does). A
    fleet run keeps its episodes under this name, so storage needs it as much as the views."""
    return f"{tail}/{asset}" if tail and not asset.startswith(f"{tail}/") else asset


@dataclasses.dataclass(frozen=True)
class Event:
    """One detected anomaly: what, where, how bad, how sure, and what is left of the part."""

    t_ns: int
    """When the anomaly was detected (Unix epoch ns, UTC): ``abs_ns`` where it is known,
    else the wall clock when the event was made. The catalog sorts and filters on it."""
    asset: str
    """The monitored unit, e.g. ``EMA1`` (the name the daemon config gives the actuator)."""
    fault: str
    """Fault mode (``esr``, ``capacitance``, ``friction``, ``short``, ``open``, ...)."""
    confidence: float
    """Classifier confidence in [0, 1]."""
    severity: float | None = None
    severity_value: float | None = None
    severity_unit: str | None = None
    rt: int | None = None
    """Remote-terminal address the asset talks through, when known."""
    switch: str | None = None
    """Faulted inverter switch for short/open (``A_high`` ...), else None."""
    soh: float | None = None
    """State of health in [0, 1] (1 = new)."""
    rul: float | None = None
    rul_low: float | None = None
    rul_high: float | None = None
    rul_unit: str | None = None
    """Unit of the three RUL figures, e.g. ``h`` (flight hours) or ``cycles``."""
    params: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """Parameter estimates (name -> value), stored as JSON."""
    evidence: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """Why the reasoner decided so (scores, thresholds, windows), stored as JSON."""
    bus_ns: int | None = None
    """Bus time of the record the event rests on (for a BIT, the request's time tag), to the
    100 ns a Chapter 10 recording keeps; None in catalogs from before schema v3."""
    abs_ns: int | None = None
    """That instant as Unix epoch ns (UTC), where known: the session clock on a live bus, a
    recording's time packets on replay (docs/service.md, "Event stamps")."""
    episode_id: int | None = None
    """The fault episode the event belongs to (:mod:`.episodes`), set by the writer; None in
    catalogs from before schema v4."""
    id: int | None = None
    session_id: int | None = None
    tail: str = ""
    """The aircraft, when the catalog knows it (read back from the BIT history: the events
    table keeps the name the daemon config gives, or a fleet run's ``TAIL/ASSET``)."""

    @property
    def name(self) -> str:
        """The actuator as every view names it: ``TAIL/ASSET`` (``mapr health``'s name)."""
        return display_name(self.tail, self.asset)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (the CLI's ``--json`` and ``export --format json`` rows)."""
        out = dataclasses.asdict(self)
        out["params"] = dict(self.params)
        out["evidence"] = dict(self.evidence)
        return out

    @property
    def severity_rank(self) -> float:
        """The severity the filters compare: the fraction, or 1.0 for a terminal fault."""
        return 1.0 if self.severity is None else self.severity


def event_from_reasoner(decision: Diagnosis, *, t_ns: int, asset: str,
                        rt: int | None = None, rul: Any = None,
                        rul_unit: str | None = "flights", bus_ns: int | None = None,
                        abs_ns: int | None = None) -> Event:
    """The catalog event for one of the reasoner's diagnoses.

    ``component``, ``part`` (the replaceable part) and ``ambiguity`` (its members'
    probabilities) are kept in the stored evidence, beside the switch and the severity as a
    fraction of range. ``rul`` (here or in the diagnosis) may be a number, a mapping with
    ``rul``/``low``/``high`` or an object with those attributes (the reasoner's
    ``RulEstimate``); the catalog never imports the reasoner, only the plain records of
    :mod:`mapr_daemon.findings`.
    """
    evidence = dict(decision.evidence)
    for key, value in (("component", decision.component), ("part", decision.part),
                       ("ambiguity", decision.ambiguity)):
        if value is not None:
            evidence.setdefault(key, value)
    estimate = rul if rul is not None else decision.rul
    value = low = high = None
    if isinstance(estimate, Mapping):
        value, low, high = estimate.get("rul"), estimate.get("low"), estimate.get("high")
    elif estimate is not None and hasattr(estimate, "rul"):
        value, low, high = estimate.rul, getattr(estimate, "low", None), \
            getattr(estimate, "high", None)
    elif estimate is not None:
        value = estimate
    return Event(
        t_ns=int(t_ns), asset=asset, rt=rt, fault=decision.fault or "unknown",
        confidence=float(decision.confidence), severity=decision.severity_fraction,
        severity_value=decision.severity, severity_unit=decision.unit,
        switch=decision.switch, soh=decision.soh,
        rul=None if value is None else float(value),
        rul_low=None if low is None else float(low),
        rul_high=None if high is None else float(high),
        rul_unit=rul_unit if value is not None else None,
        params=dict(decision.parameters), evidence=evidence,
        bus_ns=None if bus_ns is None else int(bus_ns),
        abs_ns=None if abs_ns is None else int(abs_ns))


@dataclasses.dataclass(frozen=True)
class BitOutcome:
    """One diagnosed BIT of one actuator, as the writer stores it: its anomaly event, or
    None when the BIT found the actuator nominal (which still counts towards closing that
    actuator's fault episodes, :mod:`.episodes`), with the flight it was flown on, the
    per-kind degradation estimates and the health the trend gave after it."""

    asset: str
    t_ns: int
    """When the BIT happened (epoch ns, the event's ``t_ns`` when there is one)."""
    event: Event | None = None
    tail: str = ""
    flight: int | None = None
    flight_hours: float | None = None
    """The aircraft's flight hours at the BIT (flights not seen counted at the mean)."""
    wear: Mapping[str, float] = dataclasses.field(default_factory=dict)
    """Degradation estimate per aging kind (0 healthy, 1 at the failure threshold)."""
    conditions: Mapping[str, float] = dataclasses.field(default_factory=dict)
    """The flight condition the BIT was flown at (``dynamic_pressure_pa``, ``supply_v``,
    ``ambient_c``); empty when not known."""
    wear_source: Mapping[str, Mapping[str, Any]] = dataclasses.field(default_factory=dict)
    """Per kind of ``wear``, which path read it: ``{"path": "estimator"}`` or ``{"path":
    "baseline", "record": ..., "offset": ..., "sd0": ..., "sd1": ...}``
    (:mod:`mapr_daemon.reasoner.prognosis.wear_paths`); empty when not known."""
    health: Health | None = None
    bus_ns: int | None = None
    abs_ns: int | None = None
    fault: str | None = None
    """The diagnosis (None: nominal; an anomaly's fault, as its event says)."""


@dataclasses.dataclass(frozen=True)
class BitRecord:
    """One row of an actuator's BIT history, as the reader gives it back."""

    id: int
    session_id: int | None
    tail: str
    asset: str
    t_ns: int
    bus_ns: int | None
    abs_ns: int | None
    flight: int | None
    flight_hours: float | None
    fault: str | None
    event_id: int | None
    wear: Mapping[str, float]
    health: Health
    conditions: Mapping[str, float] = dataclasses.field(default_factory=dict)
    """The flight condition the BIT was flown at; empty when not stored."""
    wear_source: Mapping[str, Mapping[str, Any]] = dataclasses.field(default_factory=dict)
    """Per kind, which path read its wear (:attr:`BitOutcome.wear_source`); empty when not
    stored (a BIT stored before schema v10)."""

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["wear"] = dict(self.wear)
        out["conditions"] = dict(self.conditions)
        out["wear_source"] = {k: dict(v) for k, v in self.wear_source.items()}
        return out


@dataclasses.dataclass(frozen=True)
class InflightEstimate:
    """One flight's in-flight estimate of one actuator, as stored (schema v9).

    ``parameters`` maps each trended parameter to ``value``, ``sd``, ``change`` (from the
    unit's baseline) and ``unit`` (:meth:`mapr_daemon.reasoner.inflight.FlightEstimate.
    as_event`); ``qualified_s`` the seconds that qualified per parameter group.
    """

    tail: str
    asset: str
    flight: int | None
    t_ns: int
    """When the flight ended (absolute ns)."""
    flight_s: float
    filtered_s: float
    parameters: Mapping[str, Mapping[str, Any]]
    qualified_s: Mapping[str, float]
    id: int | None = None
    session_id: int | None = None

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["parameters"] = {k: dict(v) for k, v in self.parameters.items()}
        out["qualified_s"] = dict(self.qualified_s)
        return out


@dataclasses.dataclass(frozen=True)
class Flight:
    """One flight of one aircraft: its number, span and hours."""

    tail: str
    flight: int
    start_ns: int | None
    end_ns: int | None
    hours: float
    source: str
    """``bus`` (measured from the actuator traffic) or ``declared`` (a replay's or fleet
    run's flight number and hours)."""

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class Session:
    """One run of the daemon: from start to stop, on one backend with one configuration."""

    id: int
    started_ns: int
    stopped_ns: int | None
    backend: str
    config_hash: str
    software_version: str
    stop_reason: str | None = None
    """``stopped``, ``SIGTERM``..., or ``unclean`` when the run was killed or lost power."""


@dataclasses.dataclass(frozen=True)
class StatsRow:
    """Bus health of one bus over one interval (counts are for that interval only)."""

    session_id: int
    start_ns: int
    end_ns: int
    bus: str
    messages: int
    words: int
    load_percent: float
    errors: Mapping[str, int]
    """Error counts by class, with the monitor's class names (``parity``, ``no_response``...)."""

    @property
    def errors_total(self) -> int:
        return sum(self.errors.values())

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["errors"] = dict(self.errors)
        out["errors_total"] = self.errors_total
        return out


@dataclasses.dataclass(frozen=True)
class Gap:
    """A stretch of time when nothing was monitored, and why (card unplugged, reasoner behind)."""

    id: int
    session_id: int | None
    start_ns: int
    end_ns: int | None
    """None while the gap is still open."""
    reason: str

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class EventFilter:
    """What ``list``/``export`` keep; every field given must match (None: any).

    ``since`` is inclusive, ``until`` exclusive, both epoch ns. ``min_severity`` compares
    :attr:`Event.severity_rank`.
    """

    since_ns: int | None = None
    until_ns: int | None = None
    asset: str | None = None
    fault: str | None = None
    min_severity: float | None = None

    def __post_init__(self) -> None:
        if self.min_severity is not None and not math.isfinite(self.min_severity):
            raise ValueError("min_severity must be a finite number")
