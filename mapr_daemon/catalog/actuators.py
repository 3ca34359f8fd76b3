"""Each actuator's standing as the catalog keeps it: newest BIT, history length, open episodes.

One :class:`ActuatorHealth` per actuator (tail and asset) with a BIT history: its newest BIT
(whose ``health`` is what the trend gave after it: SoH, leading mode, RUL with its interval,
or the note saying why there is none), how many BITs it has, when it entered service (its
first BIT) and its open fault episodes. One SQL pass over ``bits`` (a window per actuator)
finds the newest row, the count and the first BIT, so the query stays quick on a long
history. These are stored rows only; how they read (``mapr health``, its JSON, the HTML
report) is :mod:`mapr_daemon.views.health`'s.
"""

from __future__ import annotations

import dataclasses
import sqlite3

from mapr_daemon.catalog import episode_store, history
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import BitRecord, display_name
from mapr_daemon.findings import Health

__all__ = ["ActuatorHealth", "display_name", "episode_names", "episodes_of", "load"]

_LATEST = (
    f"SELECT {history.BIT_SELECT}, n, first_ns, first_flight FROM ("
    f"SELECT {history.BIT_SELECT}, row_number() OVER w_desc AS rn, count(*) OVER w AS n, "
    "min(t_ns) OVER w AS first_ns, min(flight) OVER w AS first_flight FROM bits "
    "WINDOW w AS (PARTITION BY tail, asset), w_desc AS (PARTITION BY tail, asset ORDER BY "
    "coalesce(flight, 0) DESC, t_ns DESC, id DESC)) WHERE rn = 1 ORDER BY tail, asset")


def episode_names(tail: str, asset: str) -> tuple[str, ...]:
    """The asset names an actuator's fault episodes may be kept under: its own (the daemon's)
    and ``TAIL/ASSET`` (a fleet run's, the episodes having no tail column)."""
    name = display_name(tail, asset)
    return (asset,) if name == asset else (asset, name)


def episodes_of(conn: sqlite3.Connection, tail: str, asset: str, *, open_only: bool = False
                ) -> list[Episode]:
    """The actuator's episodes (:func:`episode_names`), most recently active first."""
    found = [ep for name in episode_names(tail, asset)
             for ep in episode_store.select(conn, open_only=open_only, asset=name)]
    return sorted(found, key=lambda ep: (ep.last_ns, ep.id), reverse=True)


@dataclasses.dataclass(frozen=True)
class ActuatorHealth:
    """One actuator's standing: its newest BIT with the health after it, and its episodes."""

    tail: str
    asset: str
    last: BitRecord
    """The newest BIT (by flight, then time): its ``health`` is the actuator's health now."""
    bits: int
    """BITs in its history."""
    first_ns: int
    """In service since: the time of its first BIT (epoch ns, UTC)."""
    first_flight: int | None
    open_episodes: tuple[Episode, ...] = ()

    @property
    def name(self) -> str:
        """``tail/asset`` (just the asset when no tail is known, or when the asset already
        carries its tail, as a fleet run's ``N101/EMA1`` does)."""
        return display_name(self.tail, self.asset)

    @property
    def health(self) -> Health:
        return self.last.health


def load(conn: sqlite3.Connection, with_episodes: bool) -> list[ActuatorHealth]:
    """Every actuator with a BIT history, sorted by tail and asset; ``with_episodes``:
    the catalog has the ``episodes`` table (schema v4 on)."""
    out = []
    for row in conn.execute(_LATEST):
        record = history.bit_record(row[:-3])
        n, first_ns, first_flight = row[-3:]
        episodes = tuple(episodes_of(conn, record.tail, record.asset, open_only=True)
                         ) if with_episodes else ()
        out.append(ActuatorHealth(record.tail, record.asset, record, int(n), int(first_ns),
                                  first_flight, episodes))
    return out
