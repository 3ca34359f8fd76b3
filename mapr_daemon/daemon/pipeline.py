"""The one path from bus records to catalog events, shared by the daemon and ``mapr replay``.

::

    records -> signals (ICD) -> BIT found (:mod:`.bitwatch`) -> diagnosis (reasoner)
            -> Event (typed, stamped with bus time and absolute time, :mod:`.clock`)

:func:`build_pipeline` turns a config into a :class:`Pipeline` (the ICD, its decoder and, with
a dictionary, the reasoner wired to the asset); :meth:`Pipeline.process` takes one batch of
records and returns a :class:`Batch`: the decoded series, the BITs diagnosed, the anomaly
events ready for the catalog and the BITs the reasoner failed on. What the caller does with
them — the daemon's catalog writes, recording and systemd status, the replay's progress bar
and summary — is the caller's; what an event *is* and when it happened is decided here only,
so the daemon and a replay of its recording write the same events with the same stamps.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.catalog import BitOutcome, Event, event_from_reasoner
from mapr_daemon.daemon import source, wiring
from mapr_daemon.daemon.bitwatch import BitFound, BitWatch
from mapr_daemon.daemon.clock import BusClock, stamp
from mapr_daemon.daemon.config import AssetConfig, Config
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import Icd, Series, SignalStream, load_icd


@dataclasses.dataclass(frozen=True)
class Failure:
    """A BIT the reasoner failed on: its stamps and the error (the daemon goes on)."""

    bus_ns: int
    abs_ns: int | None
    error: str


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
    its event, or a nominal outcome that counts towards closing the asset's fault episodes."""
    failures: list[Failure]
    actuator_seen: bool
    """Whether the batch carried any of the asset's sensor channels."""


@dataclasses.dataclass
class Pipeline:
    """What a config builds and a reload swaps as one: the ICD, decoder and reasoner."""

    config: Config
    icd: Icd
    stream: SignalStream
    watch: BitWatch | None
    asset: AssetConfig

    def process(self, records: Sequence[MonitorRecord], clock: BusClock) -> Batch:
        """Decode and diagnose one batch (records in time order). ``clock`` is the
        session's: it sees the records first, then stamps the events found in them."""
        clock.observe(records)
        series = self.stream.feed(records) if records else {}
        watch = self.watch
        if watch is None:
            return Batch(series, [], [], [], [], False)
        found = watch.feed(series)
        failures = []
        for onset, error in watch.failures:
            bus = stamp(onset)
            failures.append(Failure(bus, clock.absolute(bus), error))
        outcomes = [self.outcome(bit, clock) for bit in found]
        events = [o.event for o in outcomes if o.event is not None]
        return Batch(series, found, events, outcomes, failures, watch.seen(series))

    def outcome(self, bit: BitFound, clock: BusClock) -> BitOutcome:
        """The catalog's record of one diagnosed BIT: its event if it found an anomaly,
        else a nominal outcome stamped like an event would be."""
        if bit.decision.get("anomaly"):
            event = self.event(bit, clock)
            return BitOutcome(event.asset, event.t_ns, event)
        absolute = clock.absolute(stamp(bit.request_ns))
        return BitOutcome(self.asset.name, time.time_ns() if absolute is None else absolute)

    def event(self, bit: BitFound, clock: BusClock) -> Event:
        """The catalog event of one diagnosed BIT: bus time is the request record's time tag
        (to 100 ns), absolute time the clock's; ``t_ns`` the absolute time, or the wall clock
        now when the absolute time is not known."""
        bus = stamp(bit.request_ns)
        absolute = clock.absolute(bus)
        return event_from_reasoner(bit.decision, asset=self.asset.name, rt=self.asset.rt,
                                   t_ns=time.time_ns() if absolute is None else absolute,
                                   bus_ns=bus, abs_ns=absolute)


def build_pipeline(config: Config) -> Pipeline:
    """Load the ICD, the asset's actuator file and the dictionary; ConfigError (file:line:
    field) if any is wrong or the asset's signals are not in the ICD."""
    try:
        icd = load_icd(config.icd)
    except OSError as error:
        raise ConfigError(f"cannot read the ICD {config.icd}: {error.strerror}", path=config.source,
                          field="icd") from None
    asset = config.assets[0]
    missing = wiring.not_in_icd(asset.signals, icd)
    if missing and config.reasoner.dictionary is not None:
        raise ConfigError(f"not in the ICD {icd.name}: {', '.join(missing)}",
                          path=config.source, field="assets[0].signals")
    source.check(config)
    watch = None
    if config.reasoner.dictionary is not None:
        from mapr_daemon.ema.params import load_actuator
        from mapr_daemon.reasoner.dictionary import Dictionary
        from mapr_daemon.reasoner.events import Reasoner
        try:
            dictionary = Dictionary.load(config.reasoner.dictionary)
        except OSError as error:
            raise ConfigError(f"cannot read the dictionary {config.reasoner.dictionary}: "
                              f"{error.strerror}",
                              path=config.source, field="reasoner.dictionary") from None
        params = load_actuator(asset.actuator)
        watch = BitWatch(Reasoner(dictionary, params), signals=asset.signals, bit=params.bit,
                         threshold=config.reasoner.threshold, paper=config.reasoner.paper)
    return Pipeline(config, icd, SignalStream(icd), watch, asset)
