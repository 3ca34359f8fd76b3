"""The daemon loop: bus monitor -> message table -> reasoner -> fault catalog.

One reader thread (:mod:`.reader`) owns the backend and fills a bounded queue; the main
thread owns everything else — the ICD decoder, the BIT watcher and reasoner, the SQLite
writer, the systemd notifier and the signals — so no state is shared but the queue and two
counters. Per turn the main loop drains the queue, decodes, diagnoses, writes events
(durable when ``add_events`` returns), and every ``status_interval_s`` sends STATUS (and
WATCHDOG=1 at half of WATCHDOG_USEC, only while the reader is alive and the loop turns: that
is the proof of work). Bus statistics (per bus, and per RT/SA in ``rt_stats``) go to the catalog
every ``catalog.stats_interval_s``.

The loop sleeps in ``select()`` until the reader rings its doorbell, a signal arrives through
the self-pipe (:mod:`.wakeup`) or a timer is due — no polling. SIGTERM/SIGINT flush and close
the session (exit 0 well within a second); SIGHUP reloads the config and ICD, keeping the old
ones if the new ones are invalid. A failing backend becomes a catalog gap and a retry, never
an exit; a reasoner that falls behind becomes a log line, a STATUS and a catalog gap. A
catalog write that fails keeps its BITs in memory and retries them (:mod:`.spool`), and
ended flights' in-flight rows likewise (:meth:`Service._retry_inflight`); a BIT the
reasoner fails on is counted and logged as a reasoner failure (monitoring went on: it is no
gap).
"""

from __future__ import annotations

import dataclasses
import logging
import queue
import selectors
import signal
import time
from typing import Any

from drivers.errors import BackendUnavailable
from drivers.monitor import BusStatistics
from drivers.rtstats import TrafficStatistics
from mapr_daemon import __version__
from mapr_daemon.catalog import CatalogWriter, display_name
from mapr_daemon.catalog.model import InflightEstimate
from mapr_daemon.errors import CatalogError, ConfigError
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Pipeline, build_pipeline
from mapr_daemon.service import source
from mapr_daemon.service.config import Config
from mapr_daemon.service.health_log import HealthLog, Line, Pace
from mapr_daemon.service.notify import Notifier
from mapr_daemon.service.preflight import load_checked
from mapr_daemon.service.reader import BusReader, Item
from mapr_daemon.service.recorder import SessionRecorder
from mapr_daemon.service.spool import CatalogSpool, Written
from mapr_daemon.service.wakeup import Doorbell, SignalPipe

log = logging.getLogger("mapr")
TURN_S = 0.05
"""Longest the loop handles queued work before it looks at signals and timers again."""
INFLIGHT_RETRY_S = 5.0
"""How often held in-flight rows are offered to a catalog that refused them."""
INFLIGHT_HELD = 10_000
"""In-flight rows held at most while the catalog cannot be written (a row per actuator and
flight: years of flights of a few actuators); beyond, the oldest go."""


def prepare(config: Config) -> Pipeline:
    """The pipeline ``config`` builds, with its backend's options checked as opening would
    check them (the testbed's ``testbed:`` section too): every config error at start."""
    pipe = build_pipeline(config)
    source.check(config, pipe.icd)
    return pipe


class Service:
    """One run of the daemon (see the module docstring). ``run()`` returns the exit code."""

    def __init__(self, config: Config, config_path: str | None,
                 notifier: Notifier | None = None) -> None:
        self.config_path = config_path
        self.config = config
        """The running configuration (swapped with :attr:`pipe` by a reload)."""
        self.pipe: Pipeline = prepare(config)
        self.clock = BusClock("recording" if config.backend.name == "chapter10" else "live")
        """The session's bus -> absolute time (kept across reloads: one session)."""
        self.notifier = notifier or Notifier.from_environment()
        try:
            self.catalog = CatalogWriter(
                config.catalog.path, durability=config.catalog.durability,  # type: ignore[arg-type]
                clear_after=config.catalog.episode_clear_bits)
        except CatalogError as error:
            raise ConfigError(str(error), path=config.source, field="catalog.path") from None
        self.spool = CatalogSpool(self.catalog.add_bits)
        """Diagnosed BITs on their way to the catalog, held while it cannot be written."""
        self.inflight_held: list[InflightEstimate] = []
        """Ended flights' in-flight rows the catalog could not take yet (retried, as BITs)."""
        self._inflight_retry_at = 0.0
        self.queue: queue.Queue[Item] = queue.Queue(maxsize=config.queue_batches)
        self.doorbell = Doorbell()
        self.reader: BusReader | None = None
        self.recorder: SessionRecorder | None = None
        self.stop_reason: str | None = None
        self.reload_wanted = False
        self.ready = False
        self.messages = self.errors = self.events = 0
        self.reasoner_failures = 0
        """BITs the reasoner failed on (skipped: their actuator was not diagnosed then)."""
        self.dropped = 0
        """Messages the bus reader dropped because the queue stayed full (all readers)."""
        self.queue_peak = 0
        """The most batches the queue ever held (all readers)."""
        self.busy_s = 0.0
        """Main-loop time spent handling queued work (decode, reason, write)."""
        self._reader_dropped = 0
        self.interval = BusStatistics()
        self.traffic = TrafficStatistics()
        """Per-RT/SA statistics of the current interval (to the catalog's ``rt_stats``)."""
        self.interval_start = time.time_ns()
        self.gap_id: int | None = None
        self.state = "starting"
        self._rate_count = 0
        self._rate_since = time.monotonic()
        self.rate = 0.0
        self._next_status = self._next_stats = 0.0
        self.health_log = HealthLog(config.aircraft.tail, config.health.rul_warn_flights)
        """What changed in each actuator's health: logged once per change, not per BIT."""
        self.pace = Pace(config.queue_batches)
        """Whether the input keeps up with real time and the queue stays put."""
        self.last_bus_ns: int | None = None

    # --- lifetime --------------------------------------------------------------------------
    def _start_reader(self) -> None:
        cfg = self.config
        self.reader = BusReader(source.monitor_factory(cfg, self.pipe.icd), self.queue,
                                retry_initial_s=cfg.backend.retry_initial_s,
                                retry_max_s=cfg.backend.retry_max_s, wait_s=cfg.queue_wait_s,
                                wake=self.doorbell.ring)
        self._reader_dropped = 0
        self.reader.start()

    def _stop_reader(self) -> None:
        reader, self.reader = self.reader, None
        if reader is not None:
            reader.stop()
            reader.join(timeout=0.5)
            self._report_dropped(self._note_reader(reader))   # drops up to the very end too
        while True:   # what is queued is still processed (nothing received is lost)
            try:
                self._handle(self.queue.get_nowait())
            except queue.Empty:
                break

    def run(self) -> int:
        """Monitor until SIGTERM or SIGINT, then flush and return 0. Call it from the main
        thread: signals arrive through a self-pipe (:mod:`.wakeup`)."""
        cfg = self.config
        signals = SignalPipe()
        selector = selectors.DefaultSelector()
        selector.register(signals, selectors.EVENT_READ, "signals")
        selector.register(self.doorbell, selectors.EVENT_READ, "work")
        try:
            self.catalog.open_session(backend=cfg.backend.name, config_hash=cfg.digest())
            self.pipe.resume(*self.catalog.history(cfg.aircraft.tail))  # trends continue
            self.health_log.episodes_now(self.catalog.open_episodes())   # as they stand
            reasoners = ", ".join(
                f"{display_name(cfg.aircraft.tail, w.asset.name)} "
                f"{w.asset.dictionary or cfg.reasoner.dictionary}"
                for w in self.pipe.watched if w.watch is not None)
            log.info("mapr %s: session %s, backend %s, ICD %s, catalog %s, reasoner %s",
                     __version__, self.catalog.session_id, cfg.backend.name, cfg.icd,
                     cfg.catalog.path, reasoners or "off (no dictionary)")
            if cfg.record.path is not None:
                self.recorder = SessionRecorder(cfg.record.path, self.catalog.session_id or 0,
                                                channel_id=cfg.record.channel_id,
                                                clock=self.clock, tail=cfg.aircraft.tail)
            self._start_reader()
            self._next_status = time.monotonic()
            self._next_stats = time.monotonic() + cfg.catalog.stats_interval_s
            timeout = 0.0
            while self.stop_reason is None:
                for key, _ in selector.select(timeout):
                    if key.data == "signals":
                        self._on_signals(signals.received())
                    else:
                        self.doorbell.clear()
                if self.stop_reason is not None:
                    break
                if self.reload_wanted:
                    self.reload_wanted = False
                    self.reload()
                backlog = self._work(TURN_S)
                self._check_dropped()
                self._written(self.spool.retry())
                self._retry_inflight()
                self._timers()
                timeout = 0.0 if backlog else self._until_due()
        finally:
            self._shutdown()
            selector.close()
            signals.close()
        return 0

    def _on_signals(self, received: list[signal.Signals]) -> None:
        for sig in received:
            if sig == signal.SIGHUP:
                self.reload_wanted = True
            elif self.stop_reason is None:
                self.stop_reason = sig.name

    def _work(self, limit_s: float) -> bool:
        """Handle queued items for up to ``limit_s`` (so signals and timers are seen in
        time); True when some are left."""
        started = time.perf_counter()
        try:
            while time.perf_counter() - started < limit_s:
                try:
                    item = self.queue.get_nowait()
                except queue.Empty:
                    return False
                self._handle(item)
            return not self.queue.empty()
        finally:
            self.busy_s += time.perf_counter() - started

    def _timers(self) -> None:
        now = time.monotonic()
        if now >= self._next_status:
            self._next_status = now + self.config.status_interval_s
            self._status()
        if now >= self._next_stats:
            self._next_stats = now + self.config.catalog.stats_interval_s
            self._flush_stats()
        if self._reader_alive() and self.notifier.watchdog_due():
            self.notifier.watchdog()

    def _reader_alive(self) -> bool:
        return self.reader is not None and self.reader.alive()

    def _until_due(self) -> float:
        """Seconds the loop may sleep before a timer is due (a signal or work wakes it
        sooner). The watchdog counts only while the reader lives: it is not pinged then."""
        due = [self._next_status, self._next_stats]
        retry = self.spool.due_in()
        if retry is not None:
            due.append(time.monotonic() + retry)
        watchdog = self.notifier.watchdog_next()
        if watchdog is not None and self._reader_alive():
            due.append(watchdog)
        return max(0.0, min(due) - time.monotonic())

    def _shutdown(self) -> None:
        self.notifier.stopping()
        reason = self.stop_reason or "stopped"
        log.info("stopping (%s): flushing the catalog", reason)
        self._stop_reader()
        if self.recorder is not None:
            self.recorder.close()
        self._written(self.spool.flush())   # a last try for what is held
        self._inflight(self.pipe.end_flight())   # the flight so far (a restart replaces it)
        if self.spool.held_bits:
            log.error("stopping with the catalog unwritable: %d BITs (%d events) not written",
                      self.spool.held_bits, self.spool.held_events)
        if self.inflight_held:
            log.error("stopping with the catalog unwritable: %d in-flight estimates not "
                      "written", len(self.inflight_held))
        try:
            self._flush_stats()
            if self.gap_id is not None:
                self.catalog.end_gap(self.gap_id, time.time_ns())
            self.catalog.close(reason)
        except CatalogError as error:
            log.error("closing the catalog: %s", error)
        self.notifier.close()
        self.doorbell.close()
        log.info("stopped: %d messages, %d errors, %d events; queue peak %d/%d batches, "
                 "%d messages dropped; %d reasoner failures; %d BITs (%d events) dropped "
                 "from the catalog spool", self.messages, self.errors, self.events,
                 self.queue_peak, self.queue.maxsize, self.dropped, self.reasoner_failures,
                 self.spool.dropped_bits, self.spool.dropped_events)

    # --- work ------------------------------------------------------------------------------
    def _handle(self, item: Item) -> None:
        if item.kind == "records":
            self._records(item)
        elif item.kind == "gap":
            self.state = "backend down, retrying"
            self.gap_id = self._catalog(self.catalog.record_gap, item.t_ns, None, item.reason)
            log.error("monitoring gap: %s", item.reason)
        elif item.kind == "resumed":
            self.state = "monitoring"
            if self.gap_id is not None:
                self._catalog(self.catalog.end_gap, self.gap_id, item.t_ns)
                self.gap_id = None
            log.warning("backend back after a gap")
        elif item.kind == "ended":
            self.state = "stream ended, idle"
            log.warning("%s; idle until stopped", item.reason)

    def _records(self, item: Item) -> None:
        records = item.records
        self.traffic.add_batch(records)
        for record in records:
            self.interval.add(record)
            if record.errors:
                self.errors += 1
        self.messages += len(records)
        self._rate_count += len(records)
        if records:
            self.last_bus_ns = records[-1].t_ns
        batch = self.pipe.process(records, self.clock)   # the clock sees them first
        if self.recorder is not None:
            self.recorder.write(records)
        if not self.ready:
            if self.pipe.stream.stats.decoded == 0:
                return
            self.ready = True
            self.state = "monitoring"
            self.notifier.ready(self._status_text())
            log.info("ready: backend open, first message decoded")
        for failure in batch.failures:  # its traceback logged by the watcher
            self.reasoner_failures += 1
            log.error("reasoner failure on a BIT of %s at bus time %.3f s: %s "
                      "(%d reasoner failures)",
                      display_name(self.config.aircraft.tail, failure.asset) if failure.asset
                      else "?", failure.bus_ns / 1e9,
                      failure.error, self.reasoner_failures)
        if batch.outcomes:  # the events, and every BIT's effect on the fault episodes
            self._log(self.health_log.observe(batch.outcomes))
            self._written(self.spool.submit(batch.outcomes, batch.flights))
        self._inflight(batch.inflight)

    def _inflight(self, rows: list[InflightEstimate]) -> None:
        """Ended flights' in-flight rows (per actuator) into the catalog."""
        for row in rows:
            log.info("flight %s of %s: in-flight estimate stored (%s)", row.flight,
                     display_name(self.config.aircraft.tail, row.asset),
                     ", ".join(f"{k} {p.get('change')}" for k, p in row.parameters.items()))
        self.inflight_held += rows
        self._retry_inflight(force=True)

    def _retry_inflight(self, force: bool = False) -> None:
        """Write the held in-flight rows; while the catalog cannot take them they are held
        (the newest :data:`INFLIGHT_HELD` at most) and retried every
        :data:`INFLIGHT_RETRY_S`, since the trend already counts them: a row lost would move
        the unit's in-flight baseline after a restart."""
        if not self.inflight_held or (not force and time.monotonic() < self._inflight_retry_at):
            return
        try:
            self.catalog.add_inflight(self.inflight_held)
        except CatalogError as error:
            first = self._inflight_retry_at == 0.0
            self.inflight_held = self.inflight_held[-INFLIGHT_HELD:]
            self._inflight_retry_at = time.monotonic() + INFLIGHT_RETRY_S
            (log.error if first else log.debug)(
                "catalog: %s (%d in-flight estimates held, retried every %g s)", error,
                len(self.inflight_held), INFLIGHT_RETRY_S)
            return
        self.inflight_held, self._inflight_retry_at = [], 0.0

    def _written(self, batches: list[Written]) -> None:
        """Count and log (info: the proof it is durable) the events of batches the catalog
        took, then the fault episodes those writes opened or closed (a warning when one
        opens: a persistent fault is one warning, not one per BIT)."""
        for batch in batches:
            self.events += len(batch.ids)
            for event_id, event in zip(batch.ids, batch.events, strict=True):
                log.info("event %d written: %s %s, fault %s, confidence %.2f", event_id,
                         display_name(self.config.aircraft.tail, event.asset), "anomaly",
                         event.fault, event.confidence)
        if batches:
            episodes = self._catalog(self.catalog.open_episodes)
            if episodes is not None:
                self._log(self.health_log.episodes_now(episodes))

    @staticmethod
    def _log(lines: list[Line]) -> None:
        for level, text in lines:
            log.log(level, "%s", text)

    def _catalog(self, method: Any, *args: Any) -> Any:
        """A catalog write; a failure is logged and the daemon goes on."""
        try:
            return method(*args)
        except CatalogError as error:
            log.error("catalog: %s", error)
            return None

    def _note_reader(self, reader: BusReader) -> int:
        """Fold the reader's drop count and queue peak into the totals; newly dropped."""
        lost = reader.dropped - self._reader_dropped
        self._reader_dropped = reader.dropped
        self.dropped += lost
        self.queue_peak = max(self.queue_peak, reader.high_water)
        return lost

    def _check_dropped(self) -> None:
        reader = self.reader
        if reader is None:
            return
        self._report_dropped(self._note_reader(reader))

    def _report_dropped(self, lost: int) -> None:
        """Every drop is said: a log line, a catalog gap and STATUS."""
        if not lost:
            return
        self.state = f"reasoner behind: {self.dropped} messages dropped"
        log.warning("the reasoner is behind the bus: %d messages dropped (queue full)", lost)
        now = time.time_ns()
        self._catalog(self.catalog.record_gap, now, now,
                      f"reasoner behind: {lost} messages dropped (queue full)")
        self.notifier.status(self._status_text())

    def _flush_stats(self) -> None:
        if self.recorder is not None:
            self.recorder.flush()
        end = time.time_ns()
        if self.interval.messages:
            self._catalog(self.catalog.add_stats, self.interval_start, end, self.interval)
            self._catalog(self.catalog.add_rt_stats, self.interval_start, end,
                          [dataclasses.asdict(row) for row in self.traffic.rows()])
        flights = self.pipe.pending_flights()
        if flights:
            self._catalog(self.catalog.save_flights, flights)
        self.interval = BusStatistics()
        self.traffic = TrafficStatistics()
        self.interval_start = end

    def _status_text(self) -> str:
        held = self.spool.held_bits
        return (f"{self.state}: {self.rate:.0f} msg/s, {self.messages} messages, "
                f"{self.errors} errors, {self.events} events, "
                f"queue peak {self.queue_peak}/{self.queue.maxsize}"
                + (f", {self.reasoner_failures} reasoner failures"
                   if self.reasoner_failures else "")
                + (f", {held} BITs held for the catalog" if held else ""))

    def _status(self) -> None:
        now = time.monotonic()
        self._log(self.pace.check(now, self.last_bus_ns, self.messages, self.queue.qsize()))
        span = now - self._rate_since
        if span > 0:
            self.rate = self._rate_count / span
        self._rate_count, self._rate_since = 0, now
        self.notifier.status(self._status_text())

    # --- reload ----------------------------------------------------------------------------
    def reload(self) -> None:
        """SIGHUP: new config and ICD, or the old ones kept (and the error logged)."""
        self.notifier.reloading()
        try:
            config = load_checked(self.config_path)
            pipe = prepare(config)
        except (ConfigError, BackendUnavailable) as error:
            log.error("reload failed, keeping the running configuration: %s", error)
            self.notifier.notify("READY=1", f"STATUS={self._status_text()}")
            return
        old = self.config
        if config.catalog.path != old.catalog.path:
            log.warning("catalog.path changed: takes effect at the next restart")
        if config.record != old.record:
            log.warning("record changed: takes effect at the next restart")
        restart = (config.backend, config.testbed, config.icd) != \
            (old.backend, old.testbed, old.icd)
        if restart:
            self._stop_reader()
        try:
            pipe.resume(*self.catalog.history(config.aircraft.tail))
        except CatalogError as error:
            log.error("catalog: %s (the trends restart empty)", error)
        if config.aircraft.tail == old.aircraft.tail:
            pipe.carry_inflight(self.pipe)   # the flight in progress goes on being tracked
        else:
            self._inflight(self.pipe.end_flight())
        self.pipe, self.config = pipe, config
        self.health_log.rul_warn_flights = config.health.rul_warn_flights
        if restart:
            self._start_reader()
        log.info("reloaded %s (config %s)", self.config_path or "the defaults",
                 config.digest())
        self.notifier.notify("READY=1", f"STATUS={self._status_text()}")
