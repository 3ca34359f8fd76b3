"""Catalog rows as text a maintainer reads at a glance, and as JSON-ready dicts.

Times are shown in UTC with a ``Z`` (``2026-05-09 04:13:20Z``, :func:`mapr_daemon.utc.fmt_time`),
the way flight logs are kept.
Severity shows as the share of the fault's range with the physical value beside it, as a
multiple of nominal and against the replace-at threshold
(``42% (0.449 ohm = 4.5x nominal; replace at 2x)``); a shorted or open switch shows as
``terminal``. SoH and RUL are written by :mod:`.figures`, as every other view writes them.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from typing import Any

from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import Event, Gap, Session, StatsRow
from mapr_daemon.catalog.rt_stats import RtStatsRow
from mapr_daemon.utc import fmt_time
from mapr_daemon.views.figures import rul_text, severity_text, soh_text


def fmt_duration(ns: int) -> str:
    s = ns / 1e9
    if s < 120:
        return f"{s:.0f} s" if s >= 10 else f"{s:.1f} s"
    if s < 7200:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h" if s < 172800 else f"{s / 86400:.1f} d"


def fmt_severity(e: Event, of_range: str = "") -> str:
    """``42% (0.449 ohm = 4.5x nominal; replace at 2x)``; ``of_range`` goes after the
    percentage (`` of range``)."""
    if e.severity is None:
        return "terminal"
    text = f"{100 * e.severity:.0f}%{of_range}"
    if e.severity_value is not None:
        text += f" ({severity_text(None, e.severity_value, e.severity_unit, e.evidence)})"
    return text


def fmt_rul(e: Event) -> str:
    """The event's RUL as every view writes it (``42 (30-61) flights``), ``-`` if none."""
    return rul_text(e.rul, e.rul_low, e.rul_high, e.rul_unit or "flights")


def fault_name(e: Event) -> str:
    return f"{e.fault}/{e.switch}" if e.switch else e.fault


def fmt_part(e: Event) -> str:
    """``SMPS switches (smps_ron_high 62%, smps_ron_low 38%: not separable)`` from the stored
    evidence; the part alone when no member is ambiguous; empty for events without a part."""
    amb = e.evidence.get("ambiguity")
    part = e.evidence.get("part") or (amb.get("part") if isinstance(amb, dict) else None)
    if not part:
        return ""
    if not isinstance(amb, dict) or not amb.get("ambiguous"):
        return str(part)
    members = ", ".join(f"{m['fault']} {100 * m['probability']:.0f}%"
                        for m in amb.get("members", []) if m["fault"] in amb.get("group", []))
    return f"{part} ({members}: not separable in the bus data)"


def text_table(header: Sequence[str], rows: Iterable[Sequence[str]], right: set[int]) -> str:
    """Columns as wide as their widest cell; ``right`` are right-aligned (numbers)."""
    body = [list(header), *(list(r) for r in rows)]
    widths = [max(len(r[i]) for r in body) for i in range(len(header))]
    lines = ["  ".join(c.rjust(w) if i in right else c.ljust(w)
                       for i, (c, w) in enumerate(zip(r, widths, strict=True))).rstrip()
             for r in body]
    return "\n".join(lines)


def events_table(events: Sequence[Event]) -> str:
    rows = [(str(e.id), fmt_time(e.t_ns), e.name, "-" if e.rt is None else str(e.rt),
             fault_name(e), fmt_severity(e), f"{100 * e.confidence:.0f}%", soh_text(e.soh),
             fmt_rul(e)) for e in events]
    return text_table(("ID", "TIME (UTC)", "ASSET", "RT", "FAULT", "SEVERITY", "CONF", "SOH",
                   "RUL"), rows, right={0, 3, 6, 7})


def event_detail(e: Event, session: Session | None) -> str:
    where = e.name + (f" (RT {e.rt})" if e.rt is not None else "")
    lines = [f"event {e.id}",
             f"  time        {fmt_time(e.t_ns)}",
             *([f"  bus time    {e.bus_ns / 1e9:.7f} s"] if e.bus_ns is not None else []),
             f"  asset       {where}",
             f"  fault       {fault_name(e)}",
             *([f"  part        {part}"] if (part := fmt_part(e)) else []),
             f"  severity    {fmt_severity(e, ' of range')}",
             f"  confidence  {100 * e.confidence:.0f}%",
             f"  SoH         {soh_text(e.soh)}",
             f"  RUL         {fmt_rul(e)}",
             *([f"  episode     {e.episode_id} (mapr catalog episodes)"]
               if e.episode_id is not None else [])]
    if session is not None:
        lines.append(f"  session     {session.id}: {session.backend}, config "
                     f"{session.config_hash[:12]}, MAPR {session.software_version}, "
                     f"{fmt_time(session.started_ns)} to {fmt_time(session.stopped_ns)}"
                     + (f" ({session.stop_reason})" if session.stop_reason else ""))
    if e.params:
        lines.append("  EKF estimates (the model's tracking, not a verdict: the fault and its "
                     "severity are above)")
        width = max(len(k) for k in e.params)
        lines += [f"    {k:<{width}}  {param_text(v)}" for k, v in sorted(e.params.items())]
    if e.evidence:
        lines.append("  evidence")
        lines += ["    " + line for line in
                  json.dumps(dict(e.evidence), indent=2, sort_keys=True).splitlines()]
    return "\n".join(lines)


def param_text(value: Any) -> str:
    """One EKF estimate: ``6.5 +- 1.0 x nominal (reference 1)``, its sd and reference
    beside it (an estimate far from its reference with an sd as wide says nothing yet:
    friction on a BIT with little motion)."""
    if not isinstance(value, dict):
        return f"{value:.6g}" if isinstance(value, float) else str(value)
    v, sd, unit, ref = (value.get(k) for k in ("value", "sd", "unit", "reference"))
    if not isinstance(v, (int, float)):
        return json.dumps(value, sort_keys=True)
    text = f"{v:.3g}" + (f" +- {sd:.2g}" if isinstance(sd, (int, float)) else "")
    text += f" {unit}" if unit else ""
    return text + (f" (reference {ref:.3g})" if isinstance(ref, (int, float)) else "")


def trend_table(events: Sequence[Event]) -> str:
    rows = [(fmt_time(e.t_ns), fault_name(e), fmt_severity(e), soh_text(e.soh), fmt_rul(e))
            for e in events]
    return text_table(("TIME (UTC)", "FAULT", "SEVERITY", "SOH", "RUL"), rows, right={3})


def stats_table(rows: Sequence[StatsRow]) -> str:
    def errors(r: StatsRow) -> str:
        return ", ".join(f"{k} {v}" for k, v in sorted(r.errors.items()) if v) or "-"
    body = [(fmt_time(r.start_ns), fmt_duration(r.end_ns - r.start_ns), r.bus,
             str(r.messages), str(r.words), f"{r.load_percent:.1f}", str(r.errors_total),
             errors(r)) for r in rows]
    return text_table(("START (UTC)", "LENGTH", "BUS", "MESSAGES", "WORDS", "LOAD %", "ERRORS",
                   "BY CLASS"), body, right={1, 3, 4, 5, 6})


def rt_stats_table(rows: Sequence[RtStatsRow]) -> str:
    """One line per RT / direction / subaddress or mode code (``catalog stats --by-rt``)."""
    def us(value: float | None) -> str:
        return "-" if value is None else f"{value:.1f}"

    def errors(r: RtStatsRow) -> str:
        return ", ".join(f"{k} {v}" for k, v in r.errors.items()) or "-"
    body = [(r.label, "-" if r.wc is None else str(r.wc), str(r.messages), f"{r.rate_hz:.2f}",
             us(r.response_min_us), us(r.response_mean_us), us(r.response_max_us),
             fmt_time(r.last_seen_ns), errors(r)) for r in rows]
    return text_table(("RT/SA", "WC", "MESSAGES", "RATE HZ", "RESP MIN US", "MEAN", "MAX",
                   "LAST SEEN (UTC)", "ERRORS"), body, right={1, 2, 3, 4, 5, 6})


def gaps_table(gaps: Sequence[Gap]) -> str:
    body = [(fmt_time(g.start_ns), fmt_time(g.end_ns),
             "ongoing" if g.end_ns is None else fmt_duration(g.end_ns - g.start_ns), g.reason)
            for g in gaps]
    return text_table(("GAP FROM (UTC)", "TO", "LENGTH", "REASON"), body, right={2})


def _share(value: float | None) -> str:
    return "?" if value is None else f"{100 * value:.0f}%"


def fmt_trend(ep: Episode) -> str:
    """``52%->70%`` (first -> last share of range), or ``terminal`` when none was stated."""
    if ep.sev_first is None:
        return "terminal"
    return f"{_share(ep.sev_first)}->{_share(ep.sev_last)}"


def episodes_table(episodes: Sequence[Episode]) -> str:
    """One line per fault episode (``mapr catalog episodes``)."""
    rows = [(str(ep.id), ep.name, ep.part, "+".join(ep.modes), fmt_time(ep.opened_ns),
             fmt_time(ep.last_ns), str(ep.bits), fmt_trend(ep), ep.state, ep.acked_by or "-")
            for ep in episodes]
    return text_table(("ID", "ACTUATOR", "PART", "MODE", "OPENED (UTC)", "LAST BIT (UTC)", "BITS",
                   "SEVERITY", "STATE", "ACKNOWLEDGED BY"), rows, right={0, 6})


def episode_json(ep: Episode) -> dict[str, Any]:
    return {"opened_utc": fmt_time(ep.opened_ns), "last_bit_utc": fmt_time(ep.last_ns),
            "closed_utc": None if ep.closed_ns is None else fmt_time(ep.closed_ns),
            "acked_utc": None if ep.acked_ns is None else fmt_time(ep.acked_ns), **ep.as_dict()}


def event_json(e: Event) -> dict[str, Any]:
    return {"time_utc": fmt_time(e.t_ns), **e.as_dict()}
