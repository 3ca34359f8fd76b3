"""A skeleton message table (ICD YAML) from observed traffic: what analyzers call discovery.

From the per-RT/SA statistics of a recording, capture or live bus
(:class:`drivers.rtstats.TrafficStatistics`), :func:`skeleton_yaml` writes a table in the format
of ``configs/icd/*.yaml`` (docs/icd.md) that ``mapr icd check`` accepts as written:

- one terminal per RT address seen (0-30), named ``rtNN``, its description listing the mode
  codes it was sent (mode codes are not messages in the format);
- one message per RT / direction / subaddress, named ``rtNN_t_saMM``, with the largest word
  count commanded and the rate observed, and one placeholder ``unsigned`` parameter per word
  (``rtNN_t_saMM_wKK``) for the engineer to replace with the real fields;
- an RT-RT transfer as the receiving RT's message with ``source:`` the transmitting RT's
  subaddress, unless that subaddress also talked to the bus controller on its own (then both
  are plain messages and a comment says so, since the format lets a subaddress be used once);
- broadcast traffic (RT 31) and anything else the format cannot hold as a comment;
- a Chapter 10 recording of several 1553 channels: one set of terminals per channel, each
  terminal with ``channel: N`` and named ``chN_rtMM`` (each channel is a bus, where RT 5 of
  one is not RT 5 of another), its messages' rates counted on that bus alone.

No schedule is written: the observed rates are estimates, and a schedule must reproduce them
exactly (``mapr icd check`` would reject a guess).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.words import BROADCAST_RT
from drivers.rtstats import RtSaRow, TrafficStatistics

__all__ = ["skeleton_yaml"]


def _q(text: str) -> str:
    """A YAML double-quoted scalar (a JSON string is one)."""
    return json.dumps(text, ensure_ascii=False)


def _rate(value: float) -> str:
    """The observed rate, three significant digits (0 stays 0)."""
    if value <= 0 or not math.isfinite(value):
        return "0"
    digits = max(0, 2 - math.floor(math.log10(value)))
    return f"{round(value, digits):g}"


def _key(rt: int, tr: str, sa: int) -> int:
    return rt << 11 | (tr == "T") << 10 | sa << 5


@dataclass(frozen=True, slots=True)
class _Plan:
    """Which messages become RT-RT receivers (rx key -> source (rt, sa)) and what is noted."""

    sources: dict[int, tuple[int, int]]
    consumed: set[int]
    notes: list[str]


def _plan_rt_rt(stats: TrafficStatistics, rows: dict[int, RtSaRow]) -> _Plan:
    as_source: dict[int, int] = {}
    for (_, tx), count in stats.rt_rt.items():
        as_source[tx] = as_source.get(tx, 0) + count
    sources: dict[int, tuple[int, int]] = {}
    consumed: set[int] = set()
    notes: list[str] = []
    for (rx, tx), _count in sorted(stats.rt_rt.items()):
        rx_row, tx_row = rows.get(rx), rows.get(tx)
        if rx_row is None or tx_row is None or rx_row.rt == BROADCAST_RT:
            continue
        if tx_row.messages > as_source[tx] or tx in consumed or tx_row.rt == rx_row.rt:
            notes.append(f"{rx_row.label} also receives RT-RT from {tx_row.label}, which is "
                         "listed as its own message (it also talked to the bus controller or "
                         "to another receiver)")
            continue
        sources[rx] = (tx_row.rt, tx_row.sa)
        consumed.add(tx)
    return _Plan(sources, consumed, notes)


def skeleton_yaml(stats: TrafficStatistics | Mapping[int, TrafficStatistics], *,
                  name: str = "discovered", source: str = "") -> str:
    """The skeleton table of everything ``stats`` saw, as YAML text.

    ``stats`` is one bus's statistics, or a Chapter 10 recording's per 1553 channel (channel
    ID -> statistics). Each channel is a bus of its own, so with several channels each gets
    its own terminals (``channel: N``, named ``chN_rtMM``) and messages, its rates counted on
    that bus alone; a single channel gives a table for any bus, as one bus's statistics do."""
    per_channel: dict[int | None, TrafficStatistics]
    if isinstance(stats, TrafficStatistics):
        per_channel = {None: stats}
    elif len(stats) == 1:
        per_channel = {None: next(iter(stats.values()))}
    else:
        per_channel = dict(sorted(stats.items()))
    everything = [(channel, st, st.rows()) for channel, st in per_channel.items()]
    all_rows = [r for _, _, rows in everything for r in rows]
    buses = sorted({bus for _, st, _ in everything for bus, _ in st.busy}) or ["A", "B"]
    total = sum(r.messages for r in all_rows) - sum(
        sum(st.rt_rt.values()) for _, st, _ in everything)
    span_s = ((max(r.last_ns for r in all_rows) - min(r.first_ns for r in all_rows)) / 1e9
              if all_rows else 0.0)
    out = [
        "# Skeleton message table discovered from bus traffic"
        + (f" ({source})" if source else ""),
        f"# ({total} messages over {span_s:.3f} s, from the first command to the last"
        + (f", on {len(per_channel)} 1553 channels" if None not in per_channel else "") + ").",
        "# Every name is a placeholder and every word a 16-bit 'unsigned' parameter: rename them",
        "# and replace the parameters with the real fields (docs/icd.md). Rates are as observed",
        "# on each bus; a message seen once has rate_hz 0 (aperiodic). Add a schedule to have",
        "# the bus load checked.",
        "spec: 1",
        f"name: {_q(name)}",
        "description: " + _q("Discovered from traffic" + (f" ({source})" if source else "")),
        f"buses: [{', '.join(_q(b) for b in buses)}]",
    ]
    terminals: list[str] = []
    messages: list[str] = []
    notes: list[str] = []
    for channel, st, rows in everything:
        bus = _Bus(channel)
        data_rows = {_key(r.rt, r.tr, r.sa): r for r in rows if r.mode_code is None}
        mode_rows = [r for r in rows if r.mode_code is not None]
        plan = _plan_rt_rt(st, data_rows)
        addresses = sorted({r.rt for r in rows if r.rt != BROADCAST_RT})
        terminals += _terminals(bus, addresses, mode_rows)
        for key, row in data_rows.items():
            if row.rt != BROADCAST_RT and key not in plan.consumed:
                messages += _message(bus, row, plan.sources.get(key))
        seen = list(plan.notes)
        seen += [f"{r.label} (broadcast): {r.messages} messages, wc {r.wc}"
                 for r in data_rows.values() if r.rt == BROADCAST_RT]
        seen += [f"{r.label} (broadcast mode code {MODE_CODES[r.mode_code or 0].name}): "
                 f"{r.messages} messages" for r in mode_rows if r.rt == BROADCAST_RT]
        notes += [bus.where + n for n in seen]
    out += ["terminals:", *terminals] if terminals else ["terminals: []"]
    out += ["messages:", *messages] if messages else ["messages: []"]
    if notes:
        out.append("# Seen but not representable as messages here:")
        out += [f"#   {n}" for n in notes]
    return "\n".join(out) + "\n"


@dataclass(frozen=True, slots=True)
class _Bus:
    """The channel a table part is discovered on (None: one bus, no channel written)."""

    channel: int | None

    @property
    def prefix(self) -> str:
        """Name prefix of its terminals and messages (two buses may each have an RT 5)."""
        return "" if self.channel is None else f"ch{self.channel}_"

    @property
    def where(self) -> str:
        return "" if self.channel is None else f"channel {self.channel}: "


def _terminals(bus: _Bus, addresses: list[int], mode_rows: list[RtSaRow]) -> list[str]:
    out = []
    for address in addresses:
        modes = [f"{r.tr} MC{r.mode_code:02d} {MODE_CODES[r.mode_code or 0].name} "
                 f"x{r.messages}" for r in mode_rows if r.rt == address]
        text = f"RT {address}: fill in"
        if modes:
            text += "; mode codes seen: " + ", ".join(modes)
        channel = "" if bus.channel is None else f", channel: {bus.channel}"
        out.append(f"  - {{address: {address}, name: {bus.prefix}rt{address:02d}{channel}, "
                   f"description: {_q(text)}}}")
    return out


def _message(bus: _Bus, row: RtSaRow, source: tuple[int, int] | None) -> list[str]:
    stem = f"{bus.prefix}rt{row.rt:02d}_{row.tr.lower()}_sa{row.sa:02d}"
    wc = row.wc or 1
    seen = f"seen {row.messages}x"
    if row.wc_min is not None and row.wc_min != row.wc:
        seen += f", word counts {row.wc_min}-{row.wc} (the largest is declared)"
    if row.errors:
        seen += ", errors " + ", ".join(f"{k} {v}" for k, v in row.errors.items())
    if row.response_mean_us is not None:
        seen += f", response {row.response_mean_us:.1f} us"
    out = [f"  - name: {stem}", f"    rt: {bus.prefix}rt{row.rt:02d}", f"    tr: {row.tr}",
           f"    sa: {row.sa}", f"    wc: {wc}",
           f"    rate_hz: {_rate(row.rate_hz) if row.messages > 1 else '0'}"]
    if source is not None:
        out.append(f"    source: {{rt: {bus.prefix}rt{source[0]:02d}, sa: {source[1]}}}")
    out.append(f"    description: {_q(seen)}")
    out.append("    parameters:")
    out += [f"      - {{name: {stem}_w{w:02d}, word: {w}, type: unsigned}}" for w in range(wc)]
    return out
