"""The SQLite fault catalog: what the daemon found, kept for maintainers to query.

One file (default :data:`DEFAULT_CATALOG`, the service's StateDirectory) holds monitoring
sessions, anomaly events grouped into fault episodes (:mod:`.episodes`), per-interval bus
statistics and monitoring gaps. The daemon writes
through :class:`CatalogWriter` (WAL, batched transactions, durable on return); the CLI reads
through :class:`CatalogReader` (read-only, also when the daemon is stopped). The schema is
versioned with ``PRAGMA user_version`` and migrated forward (:mod:`.schema`).

This package stores and reads; it formats nothing. How its rows read to people (tables, JSON,
CSV, plots, the HTML report) is :mod:`mapr_daemon.views`, which imports it, never the
reverse.
"""

from __future__ import annotations

import os

from mapr_daemon.catalog.actuators import ActuatorHealth, display_name
from mapr_daemon.catalog.episode_store import acknowledge
from mapr_daemon.catalog.episodes import DEFAULT_CLEAR_BITS, Episode
from mapr_daemon.catalog.model import (
    BitOutcome,
    BitRecord,
    Event,
    EventFilter,
    Flight,
    Gap,
    InflightEstimate,
    Session,
    StatsRow,
    event_from_reasoner,
)
from mapr_daemon.catalog.reader import CatalogReader
from mapr_daemon.catalog.rt_stats import RtStatsRow
from mapr_daemon.catalog.schema import LATEST as SCHEMA_VERSION
from mapr_daemon.catalog.writer import CatalogWriter
from mapr_daemon.findings import Health

DEFAULT_CATALOG = "/var/lib/mapr/catalog.sqlite"
"""Where the service keeps the catalog (systemd ``StateDirectory=mapr``)."""
ENV_CATALOG = "MAPR_CATALOG"
"""Environment variable that overrides :data:`DEFAULT_CATALOG` for the CLI."""


def default_path() -> str:
    """``$MAPR_CATALOG`` if set, else :data:`DEFAULT_CATALOG`."""
    return os.environ.get(ENV_CATALOG) or DEFAULT_CATALOG


__all__ = [
    "DEFAULT_CATALOG", "DEFAULT_CLEAR_BITS", "ENV_CATALOG", "SCHEMA_VERSION", "ActuatorHealth",
    "BitOutcome", "BitRecord", "CatalogReader", "CatalogWriter", "Episode", "Event",
    "EventFilter", "Flight", "Gap", "Health", "InflightEstimate", "RtStatsRow", "Session",
    "StatsRow", "acknowledge", "default_path", "display_name", "event_from_reasoner",
]
