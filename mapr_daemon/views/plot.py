"""``mapr catalog trend --plot`` and the report's plots: an actuator's SoH and RUL, as a PNG.

Two stacked panels over the actuator's BIT history (one point per BIT), x in flights (or in
flight hours): its state of health on 0..1 with the replace-at threshold (SoH 0) drawn and
labelled, and its remaining useful life, the median with the 90 % interval shaded and the
newest figure in the legend (its point drawn larger, as the newest SoH's is). A panel with
nothing to show says so in words (the RUL panel with the note saying why there is none).
The title carries the figures a maintainer wants first (SoH now, leading mode, RUL now), so
the plot is read in seconds.

It has to read right from one BIT to thousands: the BITs of one flight are drawn side by side
inside that flight's slot (in time order), not stacked on one x, and a flight with several
BITs is labelled with their count when there are few flights; the flight axis has integer
ticks and spans whole flights (flight 1 alone is 0.5..1.5, not matplotlib's 0.96..1.04); the
RUL axis starts at 0 and is never empty (a RUL of 0 flights everywhere, a terminal fault,
gets 0..1, not a singular axis and its warning); markers shrink as BITs multiply.

matplotlib is optional (not needed by the service); it is imported here only, with the Agg
canvas and no pyplot (no global figure state, nothing to close), so the plot works on a
headless laptop over SSH.
"""

from __future__ import annotations

import collections
import io
import itertools
import os
import textwrap
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog.model import BitRecord

NO_DATA = "no data yet"
SLOT = 0.8
"""Share of a flight's slot its BITs are spread over (the rest separates flights)."""
DENSE = 150
"""Above this many BITs the markers and lines are drawn thinner."""
COUNT_FLIGHTS = 12
"""Up to this many flights, a flight with several BITs is labelled with their count."""
PAD = 0.015
"""The x axis reaches this share of its span beyond the first and last flight (at least
half a flight), so the newest BIT's marker is not cut by the frame."""


def _x(r: BitRecord, hours: bool) -> float | None:
    if hours:
        return r.flight_hours
    return None if r.flight is None else float(r.flight)


def positions(records: Sequence[BitRecord], hours: bool = False
              ) -> list[tuple[float, BitRecord]]:
    """Each record (with a flight, or flight hours with ``hours``) at its x, in x order: the
    BITs sharing one flight (one x) spread evenly, in their given order, over :data:`SLOT` of
    the flight's slot around it, so 34 BITs of one flight read as 34 points of that flight.
    The slot is one flight, or in hours the smallest step between distinct x (one hour with a
    single x)."""
    placed = [(x, r) for r in records if (x := _x(r, hours)) is not None]
    width = _slot(sorted({x for x, _ in placed}), hours)
    groups: dict[float, list[BitRecord]] = {}
    for x, r in placed:
        groups.setdefault(x, []).append(r)
    out: list[tuple[float, BitRecord]] = []
    for x in sorted(groups):
        same = groups[x]
        n = len(same)
        out.extend((x if n == 1 else x + width * SLOT * ((i + 0.5) / n - 0.5), r)
                   for i, r in enumerate(same))
    return out


def _slot(distinct: Sequence[float], hours: bool) -> float:
    if not hours or len(distinct) < 2:
        return 1.0
    return min(b - a for a, b in itertools.pairwise(distinct))


def _title(name: str, records: Sequence[BitRecord]) -> str:
    if not records:
        return f"{name}: no BIT history"
    h = records[-1].health
    soh = "SoH ?" if h.soh is None else f"SoH {h.soh:.2f}"
    mode = f", {h.mode} leading" if h.mode else ""
    if h.rul is not None:
        band = ("" if h.rul_low is None or h.rul_high is None
                else f" ({h.rul_low:.0f}-{h.rul_high:.0f}, 90 %)")
        rul = f"; RUL {h.rul:.0f} flights{band}"
    else:
        rul = "; no RUL yet" if h.soh is None or h.soh > 0 else ""
    return f"{name}: {soh}{mode}{rul}"


def _empty(ax: Any, words: str) -> None:
    ax.text(0.5, 0.5, textwrap.fill(words, 60), transform=ax.transAxes, ha="center",
            va="center", fontsize=12, color="0.3", multialignment="center")


def _g(value: float) -> str:
    return f"{value:.0f}" if abs(value) >= 10 else f"{value:.1f}"


def _x_axis(ax: Any, points: Sequence[tuple[float, BitRecord]], hours: bool) -> None:
    """Whole flights (integer ticks, half a slot either side), flight separators and BIT
    counts when few flights hold several BITs each."""
    from matplotlib.ticker import MaxNLocator

    keys = [x for r in (p[1] for p in points) if (x := _x(r, hours)) is not None]
    if not keys:
        return
    distinct = sorted(set(keys))
    pad = max(_slot(distinct, hours) / 2, PAD * (distinct[-1] - distinct[0]))
    ax.set_xlim(distinct[0] - pad, distinct[-1] + pad)
    if not hours:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    counts = collections.Counter(keys)
    if len(distinct) <= COUNT_FLIGHTS and max(counts.values()) > 1:
        for k, n in counts.items():
            ax.text(k, 1.2, f"{n} BITs" if n > 1 else "1 BIT", ha="center", va="center",
                    fontsize=9, color="0.35")
        for a, b in itertools.pairwise(distinct):
            ax.axvline((a + b) / 2, color="0.75", lw=0.8)


def figure(records: Sequence[BitRecord], name: str, *, hours: bool = False) -> Any:
    """The plot of ``records`` (one actuator's BITs, oldest first) as a matplotlib Figure
    (``hours``: x in flight hours instead of flights). Raises ImportError without
    matplotlib."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(9, 6))
    ax_soh, ax_rul = fig.subplots(2, 1, sharex=True)
    points = positions(records, hours)
    dense = len(points) > DENSE
    ms, lw = (1.5, 0.8) if dense else (3.0, 1.2)
    soh = [(x, r.health.soh) for x, r in points if r.health.soh is not None]
    ax_soh.axhline(0.0, color="tab:red", lw=1.5, ls="--")
    ax_soh.text(0.01, 0.015, "replace-at threshold (SoH 0)", color="tab:red", fontsize=9,
                va="bottom", transform=ax_soh.get_yaxis_transform())
    if soh:
        ax_soh.plot([x for x, _ in soh], [v for _, v in soh], "o-", ms=ms, lw=lw,
                    color="tab:blue", label="state of health")
        ax_soh.plot(*soh[-1], "o", ms=6, color="tab:blue")   # now, visible among thousands
        faulted = [(x, r.health.soh) for x, r in points
                   if r.fault is not None and r.health.soh is not None]
        if faulted:
            ax_soh.plot([x for x, _ in faulted], [v for _, v in faulted], "s",
                        ms=4 if dense else 6, mfc="none", color="tab:orange",
                        label="BIT found a fault")
        ax_soh.legend(loc="upper right", fontsize=9)
    else:
        _empty(ax_soh, f"{NO_DATA}: no BIT with a state of health")
    ax_soh.set_ylim(-0.08, 1.3)
    ax_soh.set_yticks([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    ax_soh.set_ylabel("state of health (1 = new)")
    ax_soh.set_title(_title(name, records), fontsize=11)
    ax_soh.grid(True, alpha=0.3)
    _x_axis(ax_soh, points, hours)

    unit = "flight hours" if hours else "flights"
    rul = [(x, mid, lo, hi) for x, r in points
           if (mid := r.health.rul_hours if hours else r.health.rul) is not None
           for lo, hi in [(r.health.rul_hours_low, r.health.rul_hours_high) if hours
                          else (r.health.rul_low, r.health.rul_high)]]
    if rul:
        ax_rul.plot([p[0] for p in rul], [p[1] for p in rul], "o-", ms=ms, lw=lw,
                    color="tab:green", label="RUL (median)")
        band = [(x, lo, hi) for x, _, lo, hi in rul if lo is not None and hi is not None]
        if band:
            ax_rul.fill_between([b[0] for b in band], [b[1] for b in band],
                                [b[2] for b in band], color="tab:green", alpha=0.2,
                                label="90 % interval")
        top = max(max(p[1] for p in rul), max((b[2] for b in band), default=0.0))
        ax_rul.set_ylim(0.0, max(1.0, 1.15 * top))
        x, mid, lo, hi = rul[-1]
        if mid == 0 and not hi:
            words = "now: 0, at the replace-at threshold"
        else:
            words = f"now: {_g(mid)}" + (f" ({_g(lo)}-{_g(hi)})" if lo is not None
                                         and hi is not None else "") + f" {unit}"
        ax_rul.plot(x, mid, "o", ms=6, color="tab:green", ls="none", label=words)
        ax_rul.legend(loc="upper right", fontsize=9)
    else:
        last = records[-1].health.note if records else None
        _empty(ax_rul, f"no RUL: {last}" if last else f"{NO_DATA}: no RUL estimate")
        ax_rul.set_ylim(0.0, 1.0)
        ax_rul.set_yticks([])
    if not hours:
        ax_rul.yaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=2))
    ax_rul.set_ylabel(f"RUL ({unit})")
    several = len(points) > len({_x(r, hours) for _, r in points})
    label = "flight hours" if hours else "flight number"
    ax_rul.set_xlabel(label + (" (the BITs of one flight side by side, in time order)"
                               if several else ""))
    ax_rul.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def draw(records: Sequence[BitRecord], name: str, out: str | os.PathLike[str] | io.BytesIO,
         *, hours: bool = False) -> None:
    """Draw ``records`` (one actuator's BITs, oldest first) into a PNG file or buffer;
    ``hours``: x in flight hours instead of flights. Raises ImportError without matplotlib."""
    fig = figure(records, name, hours=hours)
    fig.savefig(out if isinstance(out, io.BytesIO) else os.fspath(out), dpi=100, format="png")


def png_bytes(records: Sequence[BitRecord], name: str, *, hours: bool = False) -> bytes:
    """The same plot as PNG bytes (for the HTML report)."""
    buffer = io.BytesIO()
    draw(records, name, buffer, hours=hours)
    return buffer.getvalue()
