"""``mapr report``: the fleet's health as ONE self-contained HTML file for a maintenance chief.

Everything is inside the file: the CSS inline, each trend plot inline as a base64 PNG, no
script and no network, so it opens the same on a hangar laptop, in a mail, or printed.

It reads top-down in the order a chief decides in:

1. **Fleet overview**: the tails, then every actuator, most urgent first (:func:`urgency`:
   the low end of the RUL's 90 % interval, then open fault episodes, then SoH), each with
   what to plan (:func:`plan`: replace now, replace within N flights, check an open episode,
   watch, nothing due) and a link to its section.
2. **How to read this**: SoH against the replace-at thresholds (their table comes from
   :data:`mapr_daemon.ema.degradation.FAILURE`, the thresholds the trend uses), the RUL's
   90 % interval in words, and which RUL to believe.
3. **Per actuator**, in the same order: the SoH/RUL line with the leading mode's threshold
   and the RUL in words, the service span, the trend plot (:mod:`.plot`), its fault episodes,
   and the last BIT's evidence: the diagnosis, and per trended kind its wear, z, whether it
   is wearing and its own RUL with what that RUL is (the headline, a second part wearing
   behind it, or a what-if for a part not wearing: never a forecast).
4. The bus statistics over the catalog (messages, load and errors per bus) and the
   monitoring gaps.

Without matplotlib the report is written without plots and says so.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterable, Sequence
from typing import Any

from mapr_daemon.catalog.actuators import ActuatorHealth, episode_names
from mapr_daemon.catalog.reader import CatalogReader
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.findings import Health
from mapr_daemon.utc import fmt_time
from mapr_daemon.views.figures import INFLIGHT_ORDER, inflight_change
from mapr_daemon.views.health import fmt_episodes, fmt_rul, fmt_soh
from mapr_daemon.views.text import fault_name, fmt_severity, fmt_trend

CSS = """
body{font-family:system-ui,Helvetica,Arial,sans-serif;margin:24px;color:#1b1b1b;max-width:1100px}
h1{font-size:24px;margin-bottom:4px}h2{font-size:20px;margin-top:32px;border-bottom:2px solid #ccc}
table{border-collapse:collapse;margin:8px 0 16px 0}td,th{border:1px solid #ccc;padding:4px 8px;
text-align:left;font-size:14px}th{background:#f0f0f0}.num{text-align:right;white-space:nowrap}
.line{font-size:17px;margin:8px 0}
.soh{font-weight:bold;padding:2px 8px;border-radius:4px;white-space:nowrap}
.good{background:#d8f0d8}.fair{background:#fff0c0}.poor{background:#f8d0d0}
.muted{color:#666}img{max-width:100%;border:1px solid #ddd}ul.read li{margin:4px 0}
"""

PARTS: dict[str, str] = {
    "esr": "DC-link capacitor ESR",
    "capacitance": "DC-link capacitance",
    "smps_ron_high": "SMPS high-side switch on-resistance",
    "smps_ron_low": "SMPS low-side switch on-resistance",
    "inverter_ron_a_high": "inverter phase-A high-side switch on-resistance",
    "friction": "gear train / bearing friction",
}
"""What wears, per aging mode, in a maintainer's words (docs/health.md's table)."""
TERMINAL = ("short", "open")
"""Modes that are failures at once (SoH 0, RUL 0), not wear."""
NOTHING_DUE = "nothing due"


def _e(value: Any) -> str:
    return html.escape("-" if value is None else str(value))


def _cell(value: Any) -> str:
    """A table cell's content: escaped text, or ``_Raw`` markup as it is."""
    return value.html if isinstance(value, _Raw) else _e(value)


class _Raw:
    """Markup to put into a table cell unescaped (a link, a coloured badge)."""

    def __init__(self, markup: str) -> None:
        self.html = markup


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]], num: set[int],
           cls: str = "") -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(
        f'<td class="num">{_cell(c)}</td>' if i in num else f"<td>{_cell(c)}</td>"
        for i, c in enumerate(r)) + "</tr>" for r in rows)
    attr = f' class="{cls}"' if cls else ""
    return f"<table{attr}><tr>{head}</tr>{body}</table>"


def _grade(soh: float | None) -> str:
    return "fair" if soh is None else "good" if soh >= 0.6 else "fair" if soh >= 0.3 else "poor"


def threshold(mode: str | None) -> str:
    """The leading mode's replace-at threshold in words: ``DC-link capacitor ESR: replace
    when it rises to 2x nominal``; a terminal fault's ``a terminal fault: the part has
    failed``; empty for no mode."""
    if mode is None:
        return ""
    if mode in TERMINAL:
        return "a terminal fault: the part has failed"
    ratio = FAILURE.get(mode)
    what = PARTS.get(mode, mode)
    if ratio is None:
        return what
    way = "falls to" if ratio < 1 else "rises to"
    return f"{what}: replace when it {way} {ratio:g}x nominal"


def _low(h: Health) -> float | None:
    """The low end of the RUL's interval (the median when no interval is stated)."""
    return h.rul_low if h.rul_low is not None else h.rul


def urgency(a: ActuatorHealth) -> tuple[float, int, float, str]:
    """Sort key, most urgent first: the low end of the RUL's 90 % interval (no RUL: last),
    then more open fault episodes, then lower SoH, then the name (a stable order)."""
    low = _low(a.health)
    return (math.inf if low is None else low, -len(a.open_episodes),
            1.0 if a.health.soh is None else a.health.soh, a.name)


def plan(a: ActuatorHealth) -> str:
    """What to plan, in a few words: ``replace now`` (under one flight left at the low end
    of the interval, or a terminal fault), ``replace within N flights`` (N the low end,
    rounded down: plan on it), ``check the open episode`` (a BIT detects a fault but the
    trend gives no RUL), ``watch`` (a part wears, no RUL to plan on yet) or ``nothing due``."""
    h = a.health
    low = _low(h)
    if low is not None and low < 1:
        return "replace now"
    if low is not None:
        n = math.floor(low)
        return f"replace within {n} flight{'s' if n != 1 else ''}"
    if a.open_episodes:
        return "check the open episode" + ("s" if len(a.open_episodes) > 1 else "")
    return "watch" if h.mode is not None else NOTHING_DUE


def _plan_cell(a: ActuatorHealth) -> _Raw:
    words = plan(a)
    cls = ("poor" if words == "replace now" else "" if words == NOTHING_DUE
           else "fair")
    return _Raw(f'<span class="soh {cls}">{_e(words)}</span>' if cls else _e(words))


def _link(a: ActuatorHealth) -> _Raw:
    return _Raw(f'<a href="#{_e(a.name)}">{_e(a.name)}</a>')


def rul_in_words(h: Health, flight: int | None) -> str:
    """The headline RUL as a sentence: ``RUL 15 flights, 90 % interval 10-21 (38 h): nine
    times out of ten the replace-at threshold is reached between 10 and 21 flights after
    flight 11; plan on 10.`` - or why there is none."""
    if h.rul is None:
        return f"No RUL: {h.note or 'unknown'}."
    if h.mode in TERMINAL:
        return "RUL 0: the part has failed; replace before the next flight."
    if h.rul == 0 and not h.rul_high:
        return "RUL 0: at the replace-at threshold now; replace before the next flight."
    hours = fmt_rul(h, hours=True)
    text = f"RUL {fmt_rul(h)}" + (f" ({hours})" if hours else "")
    if h.rul_low is not None and h.rul_high is not None:
        after = f" after flight {flight}" if flight is not None else " from the last BIT"
        low, high = (fmt_rul(Health(None, rul=v)).removesuffix(" flights")
                     for v in (h.rul_low, h.rul_high))
        text += (f": nine times out of ten the replace-at threshold is reached between "
                 f"{low} and {high} flights{after}; plan on {low}")
    return text + "."


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


def _kind_rul(kind: str, m: dict[str, Any], headline: Health) -> tuple[str, str]:
    """One kind's own RUL and what it is: the headline, the leading mode's figure the
    headline withholds (its note says why), a second part's projection, a what-if for a part
    not wearing, or why there is none."""
    if "rul" not in m:
        return "-", "none yet: BITs on fewer than three flights"
    if m["rul"] is None:
        return "-", "beyond the horizon: not reaching its threshold"
    figure = fmt_rul(Health(None, rul=m["rul"], rul_low=m.get("low"), rul_high=m.get("high")))
    if kind == headline.mode and headline.rul is None:
        share = m.get("prior_share")
        spans = "" if not isinstance(share, (int, float)) else \
            f"; its interval spans {100 * share:.0f} % of the assumed life's spread"
        return figure, f"withheld from the headline (see why above){spans}; not a forecast"
    if kind == headline.mode:
        return figure, "the headline RUL (leading mode)"
    if m.get("evidenced"):
        return figure, "its own projection: wearing, behind the leading mode"
    return figure, "what-if: not wearing measurably; not a forecast"


def _believe(h: Health, modes: dict[str, Any]) -> str:
    """Which RUL to believe, said where per-kind RULs stand next to the headline."""
    others = [k for k, m in modes.items()   # the leading mode's too, where it is withheld
              if isinstance(m, dict) and m.get("rul") is not None
              and (k != h.mode or h.rul is None)]
    if not others:
        return ""
    if h.rul is None:
        return (f"<p><b>No headline RUL</b> ({_e(h.note or 'unknown')}). The per-kind RULs "
                "below are what-ifs (\"if this part ages as the fleet's parts of its kind "
                "do\"), not forecasts: do not plan on them.</p>")
    return (f"<p><b>Believe the headline RUL</b>, {_e(h.mode)}'s: {_e(fmt_rul(h))}. The "
            "other kinds' RULs below are their own projections; a kind not wearing "
            "measurably gives only a what-if, never a forecast.</p>")


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
    modes = {k: m for k, m in a.health.modes.items() if isinstance(m, dict)}
    rows = []
    for kind in sorted(set(last.wear) | set(modes)):
        m: dict[str, Any] = modes.get(kind, {})
        wear = last.wear.get(kind)
        figure, what = _kind_rul(kind, m, a.health) if m else ("-", "-")
        rows.append((kind, "-" if wear is None else f"{wear:.3f}",
                     "-" if m.get("h") is None else f"{m['h']:.3f}",
                     "-" if m.get("z") is None else f"{m['z']:.1f}",
                     "yes" if m.get("evidenced") else "no", figure, what))
    lines.append(_believe(a.health, modes))
    if rows:
        lines.append(_table(("kind", "wear at this BIT (0 new, 1 replace-at)", "trend h",
                             "z vs healthy scatter", "wearing", "its own RUL (90 %)",
                             "what that RUL is"), rows, {1, 2, 3, 5}))
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


def _actuator(reader: CatalogReader, a: ActuatorHealth, rank: int) -> str:
    h = a.health
    mode = _e(h.mode) + (f" ({_e(threshold(h.mode))})" if h.mode else "")
    line = (f'<p class="line">SoH <span class="soh {_grade(h.soh)}">{_e(fmt_soh(h))}</span>'
            f" &middot; leading mode <b>{mode}</b> &middot; episodes: "
            f"{_e(fmt_episodes(a.open_episodes))} &middot; plan: {_plan_cell(a).html}</p>"
            f'<p class="line">{_e(rul_in_words(h, a.last.flight))}</p>')
    service = (f'<p class="muted">{a.bits} BITs; in service since {_e(fmt_time(a.first_ns))}'
               f" (flight {_e(a.first_flight)}); last BIT {_e(fmt_time(a.last.t_ns))} "
               f"(flight {_e(a.last.flight)}).</p>")
    return (f'<section id="{_e(a.name)}"><h2>{rank}. {_e(a.name)}</h2>{line}{service}'
            f"{_plot(reader, a)}<h3>Fault episodes</h3>{_episodes(reader, a)}"
            f"<h3>Last BIT's evidence</h3>{_evidence(reader, a)}"
            f"<h3>In-flight estimates</h3>{_inflight(reader, a)}</section>")


INFLIGHT_SHOWN = 5
"""The last flights' in-flight estimates the report lists per actuator."""


def _inflight(reader: CatalogReader, a: ActuatorHealth) -> str:
    """The actuator's last flights' in-flight estimates (change from its commissioned
    baseline per parameter, as every view writes it), beside its BIT readings above."""
    rows = [r for r in reader.inflight(a.asset, a.tail)][-INFLIGHT_SHOWN:]
    if not rows:
        return ('<p class="muted">None stored (the tracker runs between BITs; '
                "reasoner.inflight).</p>")
    names = [n for n in INFLIGHT_ORDER if any(n in r.parameters for r in rows)]
    return _table(("flight", "filtered / flight (s)", *names),
                  [(r.flight, f"{r.filtered_s:.0f} / {r.flight_s:.0f}",
                    *(inflight_change(n, r.parameters[n]).removeprefix(f"{n} ")
                      if n in r.parameters else "-" for n in names)) for r in rows], {0})


def _overview(ranked: Sequence[ActuatorHealth]) -> str:
    """The tails, most urgent first (by their most urgent actuator), then every actuator."""
    tails: dict[str, list[ActuatorHealth]] = {}
    for a in ranked:   # already most urgent first: each tail's first is its most urgent
        tails.setdefault(a.tail or "(no tail)", []).append(a)
    tail_rows = []
    for tail, group in tails.items():
        first = group[0]
        lows = [low for a in group if (low := _low(a.health)) is not None]
        due = sum(1 for a in group if plan(a) != NOTHING_DUE)
        tail_rows.append((tail, len(group), due, _link(first), _plan_cell(first),
                          "-" if not lows else fmt_rul(Health(None, rul=min(lows))),
                          sum(len(a.open_episodes) for a in group),
                          max((a.last.flight for a in group if a.last.flight is not None),
                              default=None)))
    actuator_rows = [(i, _link(a), _plan_cell(a), _Raw(
        f'<span class="soh {_grade(a.health.soh)}">{_e(fmt_soh(a.health))}</span>'),
        a.health.mode, fmt_rul(a.health) if a.health.rul is not None else
        f"none: {a.health.note or 'unknown'}", fmt_episodes(a.open_episodes),
        fmt_time(a.last.t_ns), a.last.flight) for i, a in enumerate(ranked, 1)]
    return ("<h2>Fleet overview: what needs attention first</h2>"
            '<p class="muted">Most urgent first: by the low end of the RUL\'s 90 % interval '
            "(soonest first; no RUL last), then by open fault episodes (more first), then by "
            "SoH (lower first).</p><h3>Tails</h3>"
            + _table(("tail", "actuators", "need attention", "most urgent", "its plan",
                      "lowest RUL (low end)", "open episodes", "last flight"),
                     tail_rows, {1, 2, 5, 6, 7})
            + "<h3>Actuators</h3>"
            + _table(("#", "actuator", "plan", "SoH", "leading mode", "RUL (90 % interval)",
                      "open episodes", "last BIT (UTC)", "flight"), actuator_rows, {0, 3, 8}))


def _how_to_read() -> str:
    """SoH against the thresholds, the interval in words, which RUL to believe."""
    rows = [(mode, PARTS.get(mode, mode), f"{'falls' if r < 1 else 'rises'} to {r:g}x nominal")
            for mode, r in FAILURE.items()]
    rows += [(mode, "a switch", "at once: SoH 0, RUL 0") for mode in TERMINAL]
    return ("<h2>How to read this</h2><ul class=\"read\">"
            "<li><b>SoH</b> (state of health) is read from the <b>leading mode</b>, the "
            "wearing part expected to reach its threshold first: <b>1.00</b> is the part as "
            "commissioned, <b>0.00</b> its <b>replace-at threshold</b> (below; the notes call "
            "it the failure threshold), not \"broken now\"; 0.34 means two thirds of the "
            "way there.</li>"
            "<li><b>RUL</b> (remaining useful life) counts flights from the last BIT until "
            "the leading mode reaches its replace-at threshold. <b>15 (10-21) flights</b> "
            "means: most likely 15 more flights; nine times out of ten the threshold is "
            "reached between 10 and 21 flights from now (the <b>90 % interval</b>), one time "
            "in twenty sooner than 10. <b>Plan the replacement on the low end.</b> A wide "
            "interval means a young or noisy trend; it narrows as BITs accumulate. With no "
            "RUL the line says why (no trend yet, nothing wearing, wearing too slowly to "
            "reach the threshold).</li>"
            "<li><b>Which RUL to believe</b>: the headline RUL, the leading mode's. Each "
            "kind's own RUL in an actuator's evidence table is that part's projection; for a "
            "kind that is not wearing measurably it is a what-if from the parts' expected "
            "life, never a forecast.</li>"
            "<li><b>Fault episodes</b> are what BITs detected, per replaceable part; one "
            "closes after three clear BITs in a row. A part can wear (SoH falling) before a "
            "BIT flags it.</li>"
            "<li><b>Plots</b>: one point per BIT over the flight number; the BITs of one "
            "flight side by side in its slot. Top: SoH with the replace-at threshold dashed "
            "in red, BITs that found a fault boxed in orange. Bottom: the RUL's median with "
            "its 90 % interval shaded; the newest point is drawn larger.</li></ul>"
            + _table(("mode", "what wears", "replace-at threshold (SoH 0)"), rows, set()))


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
    ranked = sorted(reader.health(), key=urgency)
    tails = len({a.tail for a in ranked})
    if ranked:
        body = (_overview(ranked) + _how_to_read()
                + "".join(_actuator(reader, a, i) for i, a in enumerate(ranked, 1)))
    else:
        body = '<p class="muted">No BIT history in this catalog yet.</p>' + _how_to_read()
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<title>MAPR actuator health</title>"
            f"<style>{CSS}</style></head><body><h1>MAPR actuator health</h1>"
            f'<p class="muted">Catalog {_e(reader.path)}, report made '
            f"{_e(fmt_time(now_ns))}: {len(ranked)} actuator{'s' if len(ranked) != 1 else ''}"
            f" on {tails} tail{'s' if tails != 1 else ''}.</p>"
            f"{body}<h2>Bus statistics</h2>{_bus(reader)}</body></html>\n")
