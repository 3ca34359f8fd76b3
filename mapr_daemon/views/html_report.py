"""``mapr report``: the fleet's health as ONE self-contained HTML file for maintainers.

Everything is inside the file: the CSS inline, each trend plot inline as a base64 PNG, no
script and no network, so it opens the same on a hangar laptop, in a mail, or printed. Per
actuator (tail/asset): the SoH/RUL line, the trend plot (:mod:`.plot`), its fault episodes,
and the last BIT's evidence (diagnosis, severity, confidence, the wear estimate of every kind
with whether it stands out of the healthy scatter). Then the bus statistics over the
catalog (messages, load and errors per bus) and the monitoring gaps. Without matplotlib the
report is written without plots and says so.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Iterable, Sequence
from typing import Any

from mapr_daemon.catalog.actuators import ActuatorHealth, episode_names
from mapr_daemon.catalog.reader import CatalogReader
from mapr_daemon.utc import fmt_time
from mapr_daemon.views.health import fmt_episodes, fmt_rul, fmt_soh
from mapr_daemon.views.text import fault_name, fmt_severity, fmt_trend

CSS = """
body{font-family:system-ui,Helvetica,Arial,sans-serif;margin:24px;color:#1b1b1b;max-width:1100px}
h1{font-size:24px;margin-bottom:4px}h2{font-size:20px;margin-top:32px;border-bottom:2px solid #ccc}
table{border-collapse:collapse;margin:8px 0 16px 0}td,th{border:1px solid #ccc;padding:4px 8px;
text-align:left;font-size:14px}th{background:#f0f0f0}.num{text-align:right}
.line{font-size:17px;margin:8px 0}.soh{font-weight:bold;padding:2px 8px;border-radius:4px}
.good{background:#d8f0d8}.fair{background:#fff0c0}.poor{background:#f8d0d0}
.muted{color:#666}img{max-width:100%;border:1px solid #ddd}
"""


def _e(value: Any) -> str:
    return html.escape("-" if value is None else str(value))


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]], num: set[int]) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(
        f'<td class="num">{_e(c)}</td>' if i in num else f"<td>{_e(c)}</td>"
        for i, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _grade(soh: float | None) -> str:
    return "fair" if soh is None else "good" if soh >= 0.6 else "fair" if soh >= 0.3 else "poor"


def _plot(reader: CatalogReader, a: ActuatorHealth) -> str:
    try:
        from mapr_daemon.views.plot import png_bytes
    except ImportError:  # pragma: no cover - matplotlib is an optional extra
        return '<p class="muted">(trend plot needs matplotlib)</p>'
    try:
        png = png_bytes(reader.bits(a.asset, a.tail), a.name)
    except ImportError:
        return '<p class="muted">(trend plot needs matplotlib)</p>'
    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="trend of {_e(a.name)}" src="data:image/png;base64,{data}">'


def _evidence(reader: CatalogReader, a: ActuatorHealth) -> str:
    last = a.last
    event = reader.event(last.event_id) if last.event_id is not None else None
    if event is None:
        verdict = f"{_e(last.fault)} (no event stored)" if last.fault else "nominal"
        lines = [f"<p>Last BIT {_e(fmt_time(last.t_ns))}, flight {_e(last.flight)}: "
                 f"{verdict}.</p>"]
    else:
        lines = [f"<p>Last BIT {_e(fmt_time(last.t_ns))}, flight {_e(last.flight)}: "
                 f"<b>{_e(fault_name(event))}</b>, severity "
                 f"{_e(fmt_severity(event, ' of range'))}, confidence "
                 f"{100 * event.confidence:.0f}%.</p>"]
    modes = a.health.modes
    rows = []
    for kind in sorted(set(last.wear) | set(modes)):
        found = modes.get(kind)
        m: dict[str, Any] = found if isinstance(found, dict) else {}
        wear = last.wear.get(kind)
        rows.append((kind, "-" if wear is None else f"{wear:.3f}",
                     "-" if m.get("h") is None else f"{m['h']:.3f}",
                     "-" if m.get("z") is None else f"{m['z']:.1f}",
                     "yes" if m.get("evidenced") else "no",
                     "-" if m.get("rul") is None else f"{m['rul']:.0f}"))
    if rows:
        lines.append(_table(("kind", "wear at this BIT (0 new, 1 failure)", "trend h",
                             "z vs healthy scatter", "wearing", "RUL (flights)"), rows,
                            {1, 2, 3, 5}))
    return "".join(lines)


def _episodes(reader: CatalogReader, a: ActuatorHealth) -> str:
    episodes = sorted((ep for name in episode_names(a.tail, a.asset)
                       for ep in reader.episodes(asset=name)),
                      key=lambda ep: (ep.last_ns, ep.id), reverse=True)
    if not episodes:
        return '<p class="muted">No fault episodes.</p>'
    return _table(("id", "part", "modes", "opened (UTC)", "last BIT (UTC)", "BITs", "severity",
                   "state", "acknowledged by"),
                  [(ep.id, ep.part, "+".join(ep.modes), fmt_time(ep.opened_ns),
                    fmt_time(ep.last_ns), ep.bits, fmt_trend(ep), ep.state, ep.acked_by)
                   for ep in episodes], {0, 5})


def _actuator(reader: CatalogReader, a: ActuatorHealth) -> str:
    h = a.health
    rul = fmt_rul(h) if h.rul is not None else "none yet"
    hours = fmt_rul(h, hours=True)
    line = (f'<p class="line">SoH <span class="soh {_grade(h.soh)}">{_e(fmt_soh(h))}</span>'
            f" &middot; leading mode <b>{_e(h.mode)}</b> &middot; RUL "
            f"{_e(rul)}{(' / ' + _e(hours)) if hours else ''} &middot; episodes: "
            f"{_e(fmt_episodes(a.open_episodes))}</p>")
    service = (f'<p class="muted">{a.bits} BITs; in service since {_e(fmt_time(a.first_ns))}'
               f" (flight {_e(a.first_flight)}); last BIT {_e(fmt_time(a.last.t_ns))} "
               f"(flight {_e(a.last.flight)}).{(' ' + _e(h.note)) if h.note else ''}</p>")
    return (f'<section id="{_e(a.name)}"><h2>{_e(a.name)}</h2>{line}{service}'
            f"{_plot(reader, a)}<h3>Fault episodes</h3>{_episodes(reader, a)}"
            f"<h3>Last BIT's evidence</h3>{_evidence(reader, a)}</section>")


def _bus(reader: CatalogReader) -> str:
    rows = reader.stats()
    if not rows:
        return '<p class="muted">No bus statistics in the catalog.</p>'
    per: dict[str, list[Any]] = {}
    for r in rows:
        acc = per.setdefault(r.bus, [0, 0, 0.0, 0.0, 0, {}, r.start_ns, r.end_ns])
        span = (r.end_ns - r.start_ns) / 1e9
        acc[0] += r.messages
        acc[1] += r.words
        acc[2] += r.load_percent * span
        acc[3] += span
        acc[4] += r.errors_total
        for k, v in r.errors.items():
            acc[5][k] = acc[5].get(k, 0) + v
        acc[6], acc[7] = min(acc[6], r.start_ns), max(acc[7], r.end_ns)
    body = [(bus, fmt_time(a[6]), fmt_time(a[7]), a[0], a[1],
             f"{a[2] / a[3]:.1f}" if a[3] > 0 else "-", a[4],
             ", ".join(f"{k} {v}" for k, v in sorted(a[5].items()) if v) or "none")
            for bus, a in sorted(per.items())]
    text = _table(("bus", "from (UTC)", "to (UTC)", "messages", "words", "mean load %",
                   "errors", "by class"), body, {3, 4, 5, 6})
    gaps = reader.gaps()
    if gaps:
        text += "<h3>Monitoring gaps</h3>" + _table(
            ("from (UTC)", "to (UTC)", "reason"),
            [(fmt_time(g.start_ns), fmt_time(g.end_ns) if g.end_ns else "open", g.reason)
             for g in gaps], set())
    return text


def build(reader: CatalogReader, now_ns: int) -> str:
    """The whole report as one HTML document (``now_ns``: when it was made, for its header)."""
    actuators = reader.health()
    summary = _table(("actuator", "SoH", "leading mode", "RUL (90 % interval)", "RUL hours",
                      "episodes", "last BIT (UTC)", "flight"),
                     [(a.name, fmt_soh(a.health), a.health.mode, fmt_rul(a.health),
                       fmt_rul(a.health, hours=True) or "-", fmt_episodes(a.open_episodes),
                       fmt_time(a.last.t_ns), a.last.flight) for a in actuators], {1, 7})
    body = "".join(_actuator(reader, a) for a in actuators) if actuators else (
        '<p class="muted">No BIT history in this catalog yet.</p>')
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<title>MAPR actuator health</title>"
            f"<style>{CSS}</style></head><body><h1>MAPR actuator health</h1>"
            f'<p class="muted">Catalog {_e(reader.path)}, report made '
            f"{_e(fmt_time(now_ns))}. SoH 1.0 is as commissioned, 0.0 the leading mode's "
            "failure threshold; RUL is in flights with its 90 % interval.</p>"
            f"{summary}{body}<h2>Bus statistics</h2>{_bus(reader)}</body></html>\n")
