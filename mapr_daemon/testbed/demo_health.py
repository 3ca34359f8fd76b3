"""The demo's diagnosis of several actuators: the daemon's pipeline, the catalog, the health.

``mapr demo`` flies two EMAs on one bus. What it does with their traffic is what the daemon
does: a :class:`~mapr_daemon.service.config.Config` with one asset per EMA (its RT, data sheet,
wiring, dictionary and prognostic model) goes to
:func:`~mapr_daemon.pipeline.pipeline.build_pipeline`; each actuator's trend continues from the
demo catalog's history and each run is declared the aircraft's next flight (so successive
demo runs are successive flights, however soon they follow each other); the BITs go into the
catalog with their fault episodes and health, and each actuator's health is read back from
the catalog as ``mapr health`` reads it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.catalog import CatalogReader, CatalogWriter
from mapr_daemon.catalog.actuators import ActuatorHealth
from mapr_daemon.catalog.model import Flight
from mapr_daemon.pipeline.bitwatch import BitFound
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Batch, build_pipeline
from mapr_daemon.pipeline.settings import AssetConfig
from mapr_daemon.service.config import Config


@dataclasses.dataclass(frozen=True)
class DemoAsset:
    """One EMA the demo diagnoses: how the daemon's ``assets[]`` entry would name it."""

    name: str
    rt: int
    actuator: Path
    signals: Mapping[str, str]
    dictionary: Path
    prognosis: Path | None = None
    """None: diagnosed, not trended (its health line says so)."""

    def config(self) -> AssetConfig:
        return AssetConfig(name=self.name, rt=self.rt, actuator=str(self.actuator),
                           signals=dict(self.signals), dictionary=str(self.dictionary),
                           prognosis=None if self.prognosis is None else str(self.prognosis))


def demo_config(icd: str | Path, assets: Sequence[DemoAsset]) -> Config:
    """The daemon configuration the demo diagnoses with: the table and one asset per EMA."""
    return Config(icd=str(icd), assets=tuple(a.config() for a in assets))


@dataclasses.dataclass(frozen=True)
class Diagnosed:
    """What the demo's traffic gave."""

    batch: Batch
    event_ids: list[int]
    health: dict[str, ActuatorHealth]
    """Each asset's standing read back from the catalog (absent: no BIT history)."""

    def bits_of(self, asset: str) -> list[BitFound]:
        """The asset's BITs diagnosed in this run, in time order."""
        return [bit for bit, o in zip(self.batch.bits, self.batch.outcomes, strict=True)
                if o.asset == asset]


def next_flight(flights: Sequence[Flight]) -> int:
    """The number of the flight after the catalog's last (1 on an empty catalog)."""
    return max((f.flight for f in flights), default=0) + 1


def diagnose_into_catalog(config: Config, records: Sequence[MonitorRecord],
                          catalog: Path) -> Diagnosed:
    """Every asset's BITs in ``records`` through the daemon's pipeline, stored in ``catalog``
    as the aircraft's next flight (trends continued from its history) and each asset's health
    read back. ConfigError if a
    dictionary or model cannot be read; CatalogError if the catalog cannot be written."""
    pipe = build_pipeline(config)
    catalog.parent.mkdir(parents=True, exist_ok=True)
    with CatalogWriter(catalog) as writer:
        bits, flights, _ = writer.history(config.aircraft.tail)
        pipe.resume(bits, flights)
        # each run is the aircraft's next flight, however soon it follows the last: told
        # from the traffic, runs within aircraft.flight_gap_s would be one flight
        pipe.declare_flight(next_flight(flights))
        writer.open_session(backend="loopback (mapr demo)", config_hash=config.digest())
        batch = pipe.process(list(records), BusClock())
        ids = writer.add_bits(batch.outcomes, batch.flights)
    names = {a.name for a in config.assets}
    with CatalogReader(catalog) as reader:
        health = {r.asset: r for r in reader.health()
                  if r.asset in names and r.tail == config.aircraft.tail}
    return Diagnosed(batch, ids, health)
