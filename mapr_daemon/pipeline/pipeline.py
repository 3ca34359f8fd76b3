"""The one path from bus records to catalog events, shared by the daemon and ``mapr replay``.

::

    records -> signals (ICD) -> BIT found, per actuator (:mod:`.bitwatch`) -> diagnosis
            (reasoner) -> flight and trend (:mod:`.trending`) -> BitOutcome / Event (typed,
            stamped with bus time and absolute time, :mod:`.clock`)

:func:`build_pipeline` turns a config into a :class:`Pipeline` (the ICD, its decoder and, for
every asset with a dictionary, a reasoner wired to that actuator, with its prognostic model
if configured); :meth:`Pipeline.process` takes one batch of records and returns a
:class:`Batch`: the decoded series, the BITs diagnosed (every actuator's, in time order), the
anomaly events ready for the catalog and the BITs the reasoner failed on. Each actuator on
the bus is diagnosed and trended on its own: its wiring, data sheet, dictionary and
prognostic model are its own (``assets[]``).

A fleet run processes recordings on workers (pipelines built with ``trend=False``) and trends
their outcomes on the client in flight order (:meth:`Pipeline.trend` of the client's own).

What the caller does with them — the daemon's catalog writes, recording and systemd status,
the replay's progress bar and summary — is the caller's; what an event *is* and when it
happened is decided here only, so the daemon and a replay of its recording write the same
events with the same stamps.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.catalog import BitOutcome, Event, event_from_reasoner
from mapr_daemon.catalog.model import BitRecord, Flight, InflightEstimate
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import Icd, Series, SignalStream, load_icd
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.bitwatch import BitFound, BitWatch
from mapr_daemon.pipeline.clock import BusClock, stamp, traffic_span
from mapr_daemon.pipeline.inflight import InflightWatch
from mapr_daemon.pipeline.settings import AssetConfig, PipelineConfig

if TYPE_CHECKING:
    from drivers.chapter10.ms1553_batch import Ms1553Batch
    from mapr_daemon.pipeline.trending import Trending
    from mapr_daemon.reasoner.commissioning.baseline import Baseline
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel


@dataclasses.dataclass(frozen=True)
class Failure:
    """A BIT the reasoner failed on: its stamps and the error (the daemon goes on)."""

    bus_ns: int
    abs_ns: int | None
    error: str
    asset: str = ""


@dataclasses.dataclass(frozen=True)
class Batch:
    """What one batch of records gave."""

    series: dict[str, Series]
    bits: list[BitFound]
    """Every BIT completed by this batch and diagnosed (nominal ones too)."""
    events: list[Event]
    """The anomalies among them, as catalog events."""
    outcomes: list[BitOutcome]
    """Every BIT of :attr:`bits` as the catalog stores it (:meth:`CatalogWriter.add_bits`):
    its event, or a nominal outcome that counts towards closing the asset's fault episodes;
    with its flight and the actuator's health after it when the pipeline trends."""
    failures: list[Failure]
    actuator_seen: bool
    """Whether the batch carried any of the assets' sensor channels."""
    flights: list[Flight] = dataclasses.field(default_factory=list)
    """Flights changed by this batch (to save with the outcomes)."""
    inflight: list[InflightEstimate] = dataclasses.field(default_factory=list)
    """Flights ended before this batch: each actuator's in-flight estimate
    (:mod:`.inflight`; :meth:`CatalogWriter.add_inflight`)."""


@dataclasses.dataclass
class Watched:
    """One actuator on the bus and its reasoner (None: monitored, not diagnosed)."""

    asset: AssetConfig
    watch: BitWatch | None


@dataclasses.dataclass
class Pipeline:
    """What a config builds and a reload swaps as one: the ICD, decoder and reasoners."""

    config: PipelineConfig
    icd: Icd
    stream: SignalStream
    watched: list[Watched]
    trending: Trending | None = None
    inflight: list[InflightWatch] = dataclasses.field(default_factory=list)
    """Each diagnosed actuator's in-flight tracker (empty: ``reasoner.inflight: false``)."""
    ended: list[InflightEstimate] = dataclasses.field(default_factory=list)
    """In-flight rows of flights ended outside :meth:`process` (a declared flight)."""

    @property
    def asset(self) -> AssetConfig:
        """The first configured actuator."""
        return self.watched[0].asset

    @property
    def watches(self) -> list[BitWatch]:
        return [w.watch for w in self.watched if w.watch is not None]

    @property
    def bits_seen(self) -> int:
        return sum(w.bits_seen for w in self.watches)

    def resume(self, bits: Sequence[BitRecord], flights: Sequence[Flight],
               inflight: Sequence[InflightEstimate] = ()) -> None:
        """Continue the trend from the catalog's history (this aircraft's rows): the BITs,
        the flights and the in-flight rows (each actuator's baseline and friction trend)."""
        for w in self.inflight:
            w.resume(inflight)
        if self.trending is None:
            return
        from mapr_daemon.pipeline.trending import Trending, history_from_bits
        self.trending = Trending(self.trending.tail, self.config.aircraft.flight_gap_s,
                                 self.trending.models, history_from_bits(bits, inflight),
                                 flights)

    def declare_flight(self, number: int, hours: float | None = None) -> None:
        """The traffic from now on is this flight (a replay's or fleet run's, known from its
        file), of ``hours`` (else its span)."""
        if self.trending is not None:
            if any(w.flight not in (None, number) for w in self.inflight):
                self.ended += self.end_flight()
            self.trending.log.declare(number, hours)

    def carry_inflight(self, old: Pipeline) -> None:
        """Keep the flight in progress across a reload: each actuator configured as before
        (same asset settings, in-flight tracking still on) keeps ``old``'s tracker state."""
        before = {w.asset: w for w in old.inflight}
        same = {w.asset.name for w in self.watched for o in old.watched
                if o.asset == w.asset and w.watch is not None}
        self.inflight = [before[w.asset] if w.asset in before and w.asset in same else w
                         for w in self.inflight]

    def end_flight(self) -> list[InflightEstimate]:
        """The flight the in-flight trackers hold has ended (a recording's end, the daemon
        stopping): each actuator's row (none where no window qualified), also added to its
        trend. The trackers start the next flight."""
        tail = self.config.aircraft.tail if self.trending is None else self.trending.tail
        rows = [r for w in self.inflight if (r := w.finish(tail)) is not None]
        if self.trending is not None:
            self.trending.add_inflight(rows)
        return rows

    def process(self, records: Sequence[MonitorRecord] | Ms1553Batch, clock: BusClock
                ) -> Batch:
        """Decode and diagnose one batch (records in time order, or a Chapter 10 reader's
        batch of columns, decoded as its records would be without building them).
        ``clock`` is the session's: it sees the records first, then stamps the events found
        in them."""
        clock.observe(records)
        series = self.stream.feed(records) if len(records) else {}
        found: list[tuple[Watched, BitFound]] = []
        failures: list[Failure] = []
        seen = False
        for w in self.watched:
            if w.watch is None:
                continue
            found += [(w, bit) for bit in w.watch.feed(series)]
            for onset, error in w.watch.failures:
                bus = stamp(onset)
                failures.append(Failure(bus, clock.absolute(bus), error, w.asset.name))
            seen |= w.watch.seen(series)
        found.sort(key=lambda wb: wb[1].request_ns)
        outcomes = [self.outcome(w.asset, bit, clock) for w, bit in found]
        flights: list[Flight] = []
        if self.trending is not None:
            end = None
            if seen and len(records):
                end = self._when(stamp(traffic_span(records)[1]), clock)
            outcomes = self.trending.annotate_batch(outcomes, end)
            flights = self.trending.log.pop_changed() if outcomes else []
        inflight = self._track(series, clock)
        events = [o.event for o in outcomes if o.event is not None]
        return Batch(series, [bit for _, bit in found], events, outcomes, failures, seen,
                     flights, inflight)

    def _track(self, series: dict[str, Series], clock: BusClock) -> list[InflightEstimate]:
        """Feed the batch to the in-flight trackers; the rows of flights that ended (the
        flight log moved on: this batch is the next flight's)."""
        rows, self.ended = self.ended, []
        if not self.inflight:
            return rows
        now = None if self.trending is None else self.trending.log.number
        if any(w.flight is not None and w.flight != now for w in self.inflight):
            rows += self.end_flight()
        for w in self.inflight:
            w.flight = now
            w.feed(series)
            if w.end_ns is not None:
                w.end_abs = self._when(stamp(w.end_ns), clock)
        return rows

    def trend(self, outcomes: Sequence[BitOutcome]) -> list[BitOutcome]:
        """Flights and health for outcomes processed elsewhere (a fleet run's workers)."""
        return list(outcomes) if self.trending is None else self.trending.annotate(outcomes)

    def pending_flights(self) -> list[Flight]:
        """Flights changed since they were last handed out (save them at intervals)."""
        return [] if self.trending is None else self.trending.log.pop_changed()

    @staticmethod
    def _when(bus: int, clock: BusClock) -> int:
        absolute = clock.absolute(bus)
        return time.time_ns() if absolute is None else absolute

    def outcome(self, asset: AssetConfig, bit: BitFound, clock: BusClock) -> BitOutcome:
        """The catalog's record of one diagnosed BIT: its event if it found an anomaly,
        else a nominal outcome stamped like an event would be; with its wear estimates."""
        bus = stamp(bit.request_ns)
        absolute = clock.absolute(bus)
        wear = dict(bit.decision.wear or {})
        cond = dict(bit.decision.conditions or {})
        source = {k: dict(v) for k, v in (bit.decision.wear_source or {}).items()}
        if bit.decision.anomaly:
            event = event_from_reasoner(bit.decision, asset=asset.name, rt=asset.rt,
                                        t_ns=time.time_ns() if absolute is None else absolute,
                                        bus_ns=bus, abs_ns=absolute)
            return BitOutcome(event.asset, event.t_ns, event, wear=wear, conditions=cond,
                              wear_source=source, bus_ns=bus, abs_ns=absolute,
                              fault=event.fault)
        return BitOutcome(asset.name, time.time_ns() if absolute is None else absolute,
                          wear=wear, conditions=cond, wear_source=source, bus_ns=bus,
                          abs_ns=absolute)


def build_pipeline(config: PipelineConfig, *, trend: bool = True) -> Pipeline:
    """Load the ICD and, for every asset with a dictionary, its actuator file, dictionary and
    prognostic model; ConfigError (file:line: field) if any is wrong or an asset's signals
    are not in the ICD. ``trend=False``: no flights or trend (:meth:`Pipeline.trend`)."""
    try:
        icd = load_icd(config.icd)
    except OSError as error:
        raise ConfigError(f"cannot read the ICD {config.icd}: {error.strerror}", path=config.source,
                          field="icd") from None
    watched: list[Watched] = []
    models: dict[str, PrognosticModel | None] = {}
    loaded: dict[str, Any] = {}
    for i, asset in enumerate(config.assets):
        path = asset.dictionary or config.reasoner.dictionary
        missing = wiring.not_in_icd(asset.signals, icd)
        if missing and path is not None:
            raise ConfigError(f"not in the ICD {icd.name}: {', '.join(missing)}",
                              path=config.source, field=f"assets[{i}].signals")
        if path is None:
            watched.append(Watched(asset, None))
            continue
        watch, model = _reasoner(config, asset, i, path, loaded)
        watched.append(Watched(asset, watch))
        models[asset.name] = model
    trending = None
    if trend and models:
        from mapr_daemon.pipeline.trending import Trending
        trending = Trending(config.aircraft.tail, config.aircraft.flight_gap_s, models)
    inflight = [watch_inflight(w.asset.name, w.watch) for w in watched
                if w.watch is not None] if getattr(config.reasoner, "inflight", True) else []
    return Pipeline(config, icd, SignalStream(icd), watched, trending, inflight)


def watch_inflight(asset: str, watch: BitWatch) -> InflightWatch:
    """The in-flight tracker of an actuator the reasoner watches (its data sheet and wiring)."""
    return InflightWatch(asset, watch.reasoner.params, watch.cutter)


def _reasoner(config: PipelineConfig, asset: AssetConfig, i: int, path: str, loaded: dict[str, Any]
              ) -> tuple[BitWatch, PrognosticModel | None]:
    """One asset's BIT watch (its own reasoner: adaptation state is per unit) and model;
    files shared by several assets are read once (``loaded``)."""
    from mapr_daemon.ema.params import load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
    from mapr_daemon.reasoner.reasoner import Reasoner
    field = f"assets[{i}].dictionary" if asset.dictionary else "reasoner.dictionary"
    if path not in loaded:
        try:
            loaded[path] = Dictionary.load(path)
        except OSError as error:
            raise ConfigError(f"cannot read the dictionary {path}: {error.strerror}",
                              path=config.source, field=field) from None
    model = None
    if asset.prognosis is not None:
        if asset.prognosis not in loaded:
            loaded[asset.prognosis] = PrognosticModel.load(asset.prognosis)
        try:
            model = loaded[asset.prognosis].with_lives(asset.expected_life_flights)
        except ConfigError as error:
            raise ConfigError(error.detail, path=config.source,
                              field=f"assets[{i}].expected_life_flights") from None
    params = load_actuator(asset.actuator)
    baseline = None if asset.commissioned is None else _baseline(config, asset, i, loaded[path])
    if model is not None and baseline is not None and baseline.wear is not None:
        model = model.against_baseline(baseline.wear.noise())   # its wear is read against it
    reasoner = Reasoner(loaded[path], params, prognostic=model, baseline=baseline)
    watch = BitWatch(reasoner, signals=asset.signals, bit=params.bit,
                     threshold=config.reasoner.threshold, paper=config.reasoner.paper)
    return watch, model


def _baseline(config: PipelineConfig, asset: AssetConfig, i: int, dictionary: Dictionary
              ) -> Baseline:
    """The asset's commissioned baseline; one ConfigError (``assets[i].commissioned``, the
    file that is wrong named in the message) when the folder cannot be used."""
    from mapr_daemon.reasoner.commissioning.baseline import Baseline
    field = f"assets[{i}].commissioned"
    assert asset.commissioned is not None
    try:
        baseline = Baseline.load(asset.commissioned)
    except ConfigError as error:
        raise ConfigError(str(error), path=config.source, field=field) from None
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ConfigError(f"cannot read the commissioning folder {asset.commissioned}: {error}",
                          path=config.source, field=field) from None
    rate = baseline.params.sensors.sample_rate_hz
    if abs(rate - dictionary.sample_rate_hz) > 1e-9:
        raise ConfigError(f"the commissioned unit {asset.commissioned} is at {rate:g} Hz, its "
                          f"dictionary at {dictionary.sample_rate_hz:g} Hz", path=config.source,
                          field=field)
    return baseline
