"""``mapr catalog export --what bits|events|episodes``: catalog tables as JSON lines or CSV.

JSON lines keep every record whole (one object per line, nested ``wear``, ``wear_source``,
``conditions`` and ``modes`` as they are). CSV is flat, one value per cell, for a spreadsheet:
a BIT's ``wear`` becomes one ``wear_<kind>`` column per aging kind and which path read it one
``source_<kind>`` column (``estimator`` or ``baseline:<record digest>``; empty for a BIT
stored before the catalog kept it), its flight condition one
``condition_<name>`` column per figure and its per-mode health one ``mode_<kind>_<figure>``
column per kind and figure (``mode_esr_rul``, ``mode_esr_h``...); an episode's modes are
joined with ``+``. The columns are the union over the rows exported, so every row has the
same header; a cell a row has no value for is empty. Events keep their long-standing CSV
(``params``/``evidence`` as JSON text) and JSON array; ``jsonl`` is added for them.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping, Sequence
from typing import IO, Any

from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import BitRecord, Event, InflightEstimate
from mapr_daemon.utc import fmt_time
from mapr_daemon.views.figures import inflight_change, inflight_json
from mapr_daemon.views.health import bit_json
from mapr_daemon.views.text import episode_json, event_json

CSV_COLUMNS = ("id", "time_utc", "t_ns", "asset", "rt", "fault", "switch", "severity",
               "severity_value", "severity_unit", "confidence", "soh", "rul", "rul_low",
               "rul_high", "rul_unit", "session_id", "params", "evidence", "bus_ns", "abs_ns",
               "episode_id", "tail")
"""Events' CSV header (``catalog export --what events --format csv``): the v1 columns, then
those added since, ``tail`` last (the aircraft, where the catalog knows it)."""
BIT_COLUMNS = ("id", "session_id", "tail", "asset", "time_utc", "t_ns", "bus_ns", "abs_ns",
               "flight", "flight_hours", "fault", "event_id", "soh", "mode", "rul", "rul_low",
               "rul_high", "rul_hours", "rul_hours_low", "rul_hours_high", "interval", "note")
EPISODE_COLUMNS = ("id", "asset", "part", "mode", "modes", "state", "opened_utc",
                   "opened_ns", "last_bit_utc", "last_ns", "closed_utc", "closed_ns", "bits",
                   "clear_bits", "sev_first", "sev_last", "sev_min", "sev_max",
                   "slope_per_bit", "acked_by", "acked_utc", "acked_ns", "ack_note", "tail")


def _cell(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return value


def flat_bit(r: BitRecord) -> dict[str, Any]:
    """One BIT as a flat row: its fields, the health after it, ``wear_<kind>``,
    ``condition_<name>`` (the flight condition it was flown at) and ``mode_<kind>_<figure>``."""
    h = r.health
    row: dict[str, Any] = {
        "id": r.id, "session_id": r.session_id, "tail": r.tail, "asset": r.asset,
        "time_utc": fmt_time(r.t_ns), "t_ns": r.t_ns, "bus_ns": r.bus_ns, "abs_ns": r.abs_ns,
        "flight": r.flight, "flight_hours": r.flight_hours, "fault": r.fault,
        "event_id": r.event_id, "soh": h.soh, "mode": h.mode, "rul": h.rul,
        "rul_low": h.rul_low, "rul_high": h.rul_high, "rul_hours": h.rul_hours,
        "rul_hours_low": h.rul_hours_low, "rul_hours_high": h.rul_hours_high,
        "interval": h.interval, "note": h.note}
    for kind, value in r.wear.items():
        row[f"wear_{kind}"] = value
    for kind, source in r.wear_source.items():
        row[f"source_{kind}"] = _source_cell(source)
    for name, value in r.conditions.items():
        row[f"condition_{name}"] = value
    for kind, figures in h.modes.items():
        if isinstance(figures, dict):
            for key, value in figures.items():
                if not isinstance(value, (dict, list)):
                    row[f"mode_{kind}_{key}"] = value
    return row


def _source_cell(source: Mapping[str, Any]) -> str:
    """A stored wear source as one word: ``estimator`` or ``baseline:<record digest>``."""
    path = str(source.get("path", ""))
    return f"{path}:{source.get('record') or '?'}" if path == "baseline" else path


def flat_episode(ep: Episode) -> dict[str, Any]:
    """One fault episode as a flat row (its modes joined with ``+``)."""
    row = episode_json(ep)
    row["modes"] = "+".join(ep.modes)
    return row


def _columns(fixed: Sequence[str], rows: Sequence[dict[str, Any]]) -> list[str]:
    extra = sorted({k for r in rows for k in r if k not in fixed})
    return [*fixed, *extra]


def _write_csv(rows: Sequence[dict[str, Any]], fixed: Sequence[str], out: IO[str]) -> int:
    columns = _columns(fixed, rows)
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    for r in rows:
        writer.writerow([_cell(r.get(c)) for c in columns])
    return len(rows)


def _write_jsonl(rows: Iterable[dict[str, Any]], out: IO[str]) -> int:
    n = 0
    for r in rows:
        out.write(json.dumps(r, sort_keys=True, allow_nan=False) + "\n")
        n += 1
    return n


INFLIGHT_COLUMNS = ("id", "session_id", "tail", "asset", "flight", "time_utc", "t_ns",
                    "flight_s", "filtered_s")
"""The fixed columns of ``catalog export --what inflight --format csv`` (then per parameter
``<name>_value``, ``_sd``, ``_change``, ``_sd_change``, ``_baseline``, ``_text``)."""
INFLIGHT_FIGURES = ("value", "sd", "change", "sd_change", "baseline")


def flat_inflight(r: InflightEstimate, prefix: str = "") -> dict[str, Any]:
    """One flight's in-flight estimate as a flat row (``prefix`` before the per-parameter
    columns: ``inflight_`` beside a BIT's)."""
    row: dict[str, Any] = {} if prefix else {
        "id": r.id, "session_id": r.session_id, "tail": r.tail, "asset": r.asset,
        "flight": r.flight, "time_utc": fmt_time(r.t_ns), "t_ns": r.t_ns,
        "flight_s": r.flight_s, "filtered_s": r.filtered_s}
    for name, p in r.parameters.items():
        for key in INFLIGHT_FIGURES:
            row[f"{prefix}{name}_{key}"] = p.get(key)
        row[f"{prefix}{name}_text"] = inflight_change(name, p)
    return row


def write_inflight(rows: Sequence[InflightEstimate], fmt: str, out: IO[str]) -> int:
    """Per-flight in-flight estimates as ``csv`` (flat) or JSON lines; the row count."""
    if fmt == "csv":
        return _write_csv([flat_inflight(r) for r in rows], INFLIGHT_COLUMNS, out)
    return _write_jsonl(({"tail": r.tail, "asset": r.asset, "time_utc": fmt_time(r.t_ns),
                          **inflight_json(r)} for r in rows), out)


def write_bits(records: Sequence[BitRecord], fmt: str, out: IO[str],
               inflight: Mapping[tuple[str, str, int | None], InflightEstimate] | None = None
               ) -> int:
    """BIT history as ``csv`` (flat) or ``jsonl``/``json`` lines; returns the row count.
    ``inflight`` by (tail, asset, flight): each BIT carries its flight's in-flight estimate
    beside its own readings (``inflight_<name>_<figure>`` columns; ``inflight`` in JSON)."""
    found = inflight or {}
    if fmt == "csv":
        rows = []
        for r in records:
            row = flat_bit(r)
            est = found.get((r.tail, r.asset, r.flight))
            if est is not None:
                row.update(flat_inflight(est, "inflight_"))
            rows.append(row)
        return _write_csv(rows, BIT_COLUMNS, out)
    return _write_jsonl(({"time_utc": fmt_time(r.t_ns), **bit_json(r),
                          "inflight": (None if (e := found.get((r.tail, r.asset, r.flight)))
                                       is None else inflight_json(e))} for r in records), out)


def write_episodes(episodes: Sequence[Episode], fmt: str, out: IO[str]) -> int:
    """Fault episodes as ``csv`` (flat) or JSON lines; returns the row count."""
    if fmt == "csv":
        return _write_csv([flat_episode(ep) for ep in episodes], EPISODE_COLUMNS, out)
    return _write_jsonl((episode_json(ep) for ep in episodes), out)


def write_events_jsonl(events: Iterable[Event], out: IO[str]) -> int:
    """Events as JSON lines (streamed)."""
    return _write_jsonl((event_json(e) for e in events), out)


def write_csv(events: Iterable[Event], out: IO[str]) -> int:
    """One row per event, ``params``/``evidence`` as JSON text; returns the row count."""
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    n = 0
    for e in events:
        d = event_json(e)
        d["params"] = json.dumps(d["params"], sort_keys=True)
        d["evidence"] = json.dumps(d["evidence"], sort_keys=True)
        writer.writerow(["" if d[c] is None else d[c] for c in CSV_COLUMNS])
        n += 1
    return n


def write_json(events: Iterable[Event], out: IO[str]) -> int:
    """A JSON array, streamed one event per line (no need to hold a million in memory)."""
    n = 0
    out.write("[")
    for e in events:
        out.write(("\n" if n == 0 else ",\n") + json.dumps(event_json(e), sort_keys=True))
        n += 1
    out.write("\n]\n" if n else "]\n")
    return n
