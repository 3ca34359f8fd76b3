"""Each tail's flights and actuator trends, on the client, in flight order.

Workers diagnose a recording with a pipeline built ``trend=False``: their outcomes carry each
BIT's degradation estimates (``wear``) but no flight and no health, because the trend of an
actuator needs every earlier flight of its tail, which only the client sees in order
(:class:`~mapr_daemon.fleet.runner.FlightOrder`). :class:`FleetTrend` keeps one trending
pipeline per tail, continued from the catalog's history of that tail (the ``bits`` and
``flights`` rows with its ``tail``, as ``mapr replay`` and the daemon continue theirs), and
for each recording declares its flight and hours and trends its outcomes
(:meth:`Pipeline.declare_flight`, :meth:`Pipeline.trend`): the outcomes come back with
``tail``, ``flight``, ``flight_hours`` and ``health`` (SoH, leading mode, RUL), ready to be
stored with the flights in the recording's one transaction.

The expensive part of a pipeline (ICD, dictionary, prognostic models) is built once per
configuration; a tail gets its own :class:`~mapr_daemon.pipeline.trending.Trending` on it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from mapr_daemon.catalog import BitOutcome
from mapr_daemon.catalog.model import Flight, InflightEstimate
from mapr_daemon.catalog.writer import CatalogWriter
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.pipeline.pipeline import Pipeline, build_pipeline
from mapr_daemon.pipeline.trending import Trending
from mapr_daemon.service.config import Config


class FleetTrend:
    """One trending pipeline per tail (see the module docstring)."""

    def __init__(self, catalog: CatalogWriter, configs: FleetConfig) -> None:
        self.catalog, self.configs = catalog, configs
        self._built: dict[str, Pipeline] = {}
        self._tails: dict[str, Pipeline] = {}

    def pipeline(self, tail: str) -> Pipeline:
        """The tail's trending pipeline, resumed from the catalog on first use."""
        pipe = self._tails.get(tail)
        if pipe is None:
            base = self._base(self.configs.for_tail(tail))
            trending = None if base.trending is None else Trending(
                tail, base.config.aircraft.flight_gap_s, base.trending.models)
            from mapr_daemon.pipeline.pipeline import watch_inflight
            inflight = [watch_inflight(w.asset.name, w.watch) for w in base.watched
                        if w.watch is not None] if base.inflight else []
            pipe = dataclasses.replace(base, trending=trending, inflight=inflight, ended=[])
            pipe.resume(*self.catalog.history(tail))
            self._tails[tail] = pipe
        return pipe

    def _base(self, config: Config) -> Pipeline:
        key = f"{config.digest()}:{config.source}"
        base = self._built.get(key)
        if base is None:
            base = self._built[key] = build_pipeline(config)
        return base

    def flight(self, tail: str, flight: int, hours: float | None,
               outcomes: Sequence[BitOutcome], inflight: Sequence[InflightEstimate] = ()
               ) -> tuple[list[BitOutcome], list[Flight], list[InflightEstimate]]:
        """One recording of ``tail``: its outcomes trended as flight ``flight`` of ``hours``,
        the flights to store with them, and its in-flight rows against each actuator's
        baseline (which they then join, as the trend does)."""
        pipe = self.pipeline(tail)
        pipe.declare_flight(flight, hours)
        trended = pipe.trend(outcomes)
        watches = {w.asset: w for w in pipe.inflight}
        rows = [dataclasses.replace(r, parameters=watches[r.asset].baseline.rebase(
            r.parameters, r.flight)) for r in inflight if r.asset in watches]
        if pipe.trending is not None:
            pipe.trending.add_inflight(rows)
        return trended, pipe.pending_flights(), rows

    def forget(self, tail: str) -> None:
        """Drop the tail's state (its next recording resumes from the catalog): after a
        store that was refused, the in-memory trend holds BITs the catalog does not."""
        self._tails.pop(tail, None)
