"""Per-RT/SA bus statistics in the catalog: the rows the daemon writes and the summary read back.

Each statistics interval the daemon stores one ``rt_stats`` row per RT / direction /
subaddress (or mode code) that carried traffic, with the counts of that interval only:
messages, errors by class, the number and the sum of the response gaps (so a mean over any
range is exact), their minimum and maximum, and the last bus time seen. :func:`summary` folds
the rows of a time range into one :class:`RtStatsRow` per key (``mapr catalog stats --by-rt``).

The writer takes the rows as mappings with the field names of
:class:`drivers.rtstats.RtSaRow` (``dataclasses.asdict`` of it), so the catalog does not
import the monitor.
"""

from __future__ import annotations

import dataclasses
import json
import sqlite3
from collections.abc import Iterable, Mapping
from typing import Any

RT_STATS_SINCE = 6
"""The schema version that added the ``rt_stats`` table."""

INSERT = ("INSERT INTO rt_stats (session_id, start_ns, end_ns, rt, tr, sa, mode_code, wc, "
          "messages, errors_total, errors, responses, response_sum_ns, response_min_ns, "
          "response_max_ns, last_bus_ns) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")


def insert_rows(session_id: int, start_ns: int, end_ns: int,
                rows: Iterable[Mapping[str, Any]]) -> list[tuple[Any, ...]]:
    """The parameters of :data:`INSERT` for one interval's rows."""
    out = []
    for row in rows:
        errors = {str(k): int(v) for k, v in dict(row.get("errors", {})).items() if v}
        out.append((session_id, start_ns, end_ns, int(row["rt"]), str(row["tr"]),
                    int(row["sa"]), _opt(row.get("mode_code")), _opt(row.get("wc")),
                    int(row["messages"]), sum(errors.values()),
                    json.dumps(errors, sort_keys=True), int(row.get("responses", 0)),
                    int(row.get("response_sum_ns", 0)), _opt(row.get("response_min_ns")),
                    _opt(row.get("response_max_ns")), int(row["last_ns"])))
    return out


def _opt(value: Any) -> int | None:
    return None if value is None else int(value)


@dataclasses.dataclass(frozen=True)
class RtStatsRow:
    """One RT / direction / subaddress (or mode code) over a range of intervals."""

    rt: int
    tr: str
    sa: int
    mode_code: int | None
    wc: int | None
    messages: int
    rate_hz: float
    """Messages per second over the intervals of the range that carried any traffic."""
    errors: Mapping[str, int]
    response_min_us: float | None
    response_mean_us: float | None
    response_max_us: float | None
    last_seen_ns: int
    """End of the last interval (wall clock, epoch ns) in which the key had traffic."""

    @property
    def label(self) -> str:
        if self.mode_code is not None:
            return f"RT{self.rt:02d} {self.tr} MC{self.mode_code:02d}"
        return f"RT{self.rt:02d} {self.tr} SA{self.sa:02d}"

    @property
    def errors_total(self) -> int:
        return sum(self.errors.values())

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["errors"] = dict(self.errors)
        return out


_KEY = "rt, tr, sa, coalesce(mode_code, -1)"


def summary(conn: sqlite3.Connection, since_ns: int | None = None,
            until_ns: int | None = None) -> list[RtStatsRow]:
    """One row per key with traffic in intervals starting in [since, until), by RT/T-R/SA."""
    clauses, values = [], []
    if since_ns is not None:
        clauses.append("start_ns >= ?")
        values.append(int(since_ns))
    if until_ns is not None:
        clauses.append("start_ns < ?")
        values.append(int(until_ns))
    where = " WHERE " + " AND ".join(clauses) if clauses else ""
    (monitored,) = conn.execute(
        "SELECT coalesce(sum(end_ns - start_ns), 0) FROM (SELECT DISTINCT session_id, "
        f"start_ns, end_ns FROM rt_stats{where})", values).fetchone()
    errors: dict[tuple[int, str, int, int], dict[str, int]] = {}
    for rt, tr, sa, mc, name, count in conn.execute(
            f"SELECT {_KEY}, e.key, sum(e.value) FROM rt_stats, json_each(rt_stats.errors) e"
            f"{where} GROUP BY {_KEY}, e.key", values):
        errors.setdefault((rt, tr, sa, mc), {})[name] = int(count)
    out = []
    for rt, tr, sa, mc, wc, n, resp_n, resp_sum, resp_min, resp_max, last in conn.execute(
            f"SELECT {_KEY}, max(wc), sum(messages), sum(responses), sum(response_sum_ns), "
            f"min(response_min_ns), max(response_max_ns), max(end_ns) FROM rt_stats{where} "
            f"GROUP BY {_KEY} ORDER BY rt, tr, mode_code IS NOT NULL, sa, mode_code", values):
        out.append(RtStatsRow(
            rt=rt, tr=tr, sa=sa, mode_code=None if mc < 0 else mc, wc=wc, messages=n,
            rate_hz=n * 1e9 / monitored if monitored > 0 else 0.0,
            errors=dict(sorted(errors.get((rt, tr, sa, mc), {}).items())),
            response_min_us=None if resp_min is None else resp_min / 1e3,
            response_mean_us=resp_sum / resp_n / 1e3 if resp_n else None,
            response_max_us=None if resp_max is None else resp_max / 1e3,
            last_seen_ns=last))
    return out
