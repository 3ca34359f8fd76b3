"""The catalog as people read it: text tables, JSON and CSV, plots and the HTML report.

:mod:`mapr_daemon.catalog` stores and reads; this package only presents what it reads, so
it may import the catalog and never the reverse (storage imports no formatting). Its face is
the text and data views the CLI prints and exports:

* :mod:`.text`: events, episodes, bus statistics and gaps as aligned tables and JSON-ready
  dicts;
* :mod:`.health`: each actuator's health (``mapr health``) and a BIT history (``catalog
  trend``);
* :mod:`.export`: ``catalog export``'s CSV, JSON and JSON lines.

:mod:`.plot` (matplotlib, an optional dependency) and :mod:`.html_report` (``mapr report``,
which draws the plots) are imported by module where they are used, so a command that prints
text never loads them.
"""

from __future__ import annotations

from mapr_daemon.views.export import (
    write_bits,
    write_csv,
    write_episodes,
    write_events_jsonl,
    write_inflight,
    write_json,
)
from mapr_daemon.views.health import bit_json, bits_table, health_json, health_table
from mapr_daemon.views.text import (
    episode_json,
    episodes_table,
    event_detail,
    event_json,
    events_table,
    gaps_table,
    rt_stats_table,
    stats_table,
    trend_table,
)

__all__ = [
    "bit_json", "bits_table", "episode_json", "episodes_table", "event_detail", "event_json",
    "events_table", "gaps_table", "health_json", "health_table", "rt_stats_table",
    "stats_table", "trend_table", "write_bits", "write_csv", "write_episodes",
    "write_events_jsonl", "write_inflight", "write_json",
]
