"""Each actuator's per-flight in-flight estimates, in the catalog (schema v9).

Between BITs the pipeline tracks the actuator's parameters on the flight's own traffic
(:mod:`mapr_daemon.reasoner.inflight`); each flight ends with one estimate per trended
parameter (value, sd, change from the unit's commissioned baseline, unit) and the seconds of
the flight that qualified for each parameter group. That is an ``inflight`` row, one per
tail, actuator and flight: storing the same flight again (a replay rerun) replaces it.

Functions take an open connection; the writer calls :func:`insert_inflight` inside its
transaction, the reader :func:`load_inflight`.
"""

from __future__ import annotations

import json
import math
import sqlite3
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog.history import equal_to
from mapr_daemon.catalog.model import InflightEstimate

INFLIGHT_SINCE = 9
"""Schema version that added the ``inflight`` table."""


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _json(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"), allow_nan=False, default=float)


def insert_inflight(conn: sqlite3.Connection, session_id: int | None,
                    estimates: Sequence[InflightEstimate]) -> None:
    """Store flights' estimates (replacing an earlier row of the same tail, asset, flight)."""
    conn.executemany(
        "INSERT INTO inflight (session_id, tail, asset, flight, t_ns, flight_s, filtered_s,"
        " parameters, qualified) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)"
        " ON CONFLICT (tail, asset, flight) DO UPDATE SET session_id = excluded.session_id,"
        " t_ns = excluded.t_ns, flight_s = excluded.flight_s,"
        " filtered_s = excluded.filtered_s, parameters = excluded.parameters,"
        " qualified = excluded.qualified",
        [(session_id, e.tail, e.asset, e.flight, int(e.t_ns), float(e.flight_s),
          float(e.filtered_s),
          _json({k: {f: _finite(v) for f, v in p.items()} for k, p in e.parameters.items()}),
          _json({k: float(v) for k, v in e.qualified_s.items()})) for e in estimates])


def load_inflight(conn: sqlite3.Connection, asset: str | None = None,
                  tail: str | None = None) -> list[InflightEstimate]:
    """Per-flight estimates (all actuators, or one), oldest flight first."""
    where, args = equal_to(asset=asset, tail=tail)
    sql = ("SELECT id, session_id, tail, asset, flight, t_ns, flight_s, filtered_s, parameters,"
           f" qualified FROM inflight{where}")
    sql += " ORDER BY tail, asset, coalesce(flight, 0), t_ns, id"
    return [InflightEstimate(tail=r[2], asset=r[3], flight=r[4], t_ns=int(r[5]),
                             flight_s=float(r[6]), filtered_s=float(r[7]),
                             parameters=json.loads(r[8]), qualified_s=json.loads(r[9]),
                             id=int(r[0]), session_id=r[1])
            for r in conn.execute(sql, args)]
