"""``mapr icd dump``: each message's bit layout drawn in ASCII, as ``cantools dump`` does.

Every word is a row of 16 cells, bit 15 (first on the bus) on the left. A field is drawn as
``<----x`` from its most significant bit (``<``) to its least significant bit (``x``); a field
that continues in another word (two-word values) ends in ``-`` instead. A repeating group is
drawn once, for its first sample. A table of the parameters follows each drawing.
"""

from __future__ import annotations

from mapr_daemon.icd.database import Icd
from mapr_daemon.icd.model import Message, Parameter, ParamType

_RULE = "       +" + "---+" * 16
_BITS = "        " + "".join(f"{b:>3} " for b in range(15, -1, -1)).rstrip()


def dump_icd(icd: Icd) -> str:
    """The whole table: header, terminals, schedule, then every message."""
    out = [f"ICD {icd.name} (spec 1): {icd.description}".rstrip(": "),
           f"Buses: {', '.join(icd.buses)}", "Terminals:"]
    out += [f"  RT{t.address:02d} {t.name:<12} {t.description}".rstrip() for t in icd.terminals]
    load = icd.bus_load()
    if icd.schedule is not None and load is not None:
        s = icd.schedule
        out.append(f"Schedule: {s.minor_frames} minor frames of {s.minor_frame_us} µs "
                   f"(major frame {s.major_frame_us / 1000:g} ms), response {s.response_time_us:g}"
                   f" µs, gap {s.intermessage_gap_us:g} µs")
        out.append(f"Bus load: {100 * load.load:.1f} % average, busiest minor frame "
                   f"{100 * load.peak_frame_load:.1f} %, {load.words_per_s:.0f} words/s")
    for message in icd.messages:
        out.append("")
        out.append(dump_message(message))
    return "\n".join(out) + "\n"


def dump_message(m: Message) -> str:
    """One message: title, drawing and parameter table."""
    title = f" {m.name} "
    out = [f"{title:=^79}"]
    where = f"RT{m.rt:02d} ({m.rt_name}) {m.tr} SA{m.subaddress:02d}"
    if m.source is not None:
        where += f" <- RT{m.source[0]:02d} T SA{m.source[1]:02d}"
    rate = f"{m.rate_hz:g} Hz" if m.rate_hz else "aperiodic"
    words = "word" if m.word_count == 1 else "words"
    out.append(f"  {where}   {m.kind}   {m.word_count} {words}   {rate}")
    if m.description:
        out.append(f"  {m.description}")
    out += ["", _BITS, _RULE]
    placed = [(p, 0) for p in m.parameters]
    g = m.group
    group_words: set[int] = set()
    if g is not None:
        placed += [(c, g.start) for c in g.channels]
        group_words = set(range(g.start + g.stride, g.start + g.samples * g.stride))
    for word in range(m.word_count):
        if word in group_words:
            continue
        out.append(_row(word, placed))
        out.append(_RULE)
        if g is not None and word == g.start + g.stride - 1 and g.samples > 1:
            first, last = g.start + g.stride, g.start + g.samples * g.stride - 1
            out.append(f"       words {first}-{last}: samples 1-{g.samples - 1}, same layout")
            out.append(_RULE)
    out.append("")
    out += _table(m)
    return "\n".join(out)


def _row(word: int, placed: list[tuple[Parameter, int]]) -> str:
    """One word drawn as cells, with the names of the fields it holds."""
    cells: list[Parameter | None] = [None] * 16   # index = 15 - bit
    bases: dict[str, int] = {}
    names: list[tuple[int, str]] = []
    for p, base in placed:
        indices = p.word_indices(base)
        if word not in indices:
            continue
        part = ""
        if p.words == 2:
            is_msw = word == indices[0]
            part = " (msw)" if is_msw else " (lsw)"
            hi, lo = (31, 16) if is_msw else (15, 0)
            msb, lsb = min(p.msb, hi) - lo, max(p.lsb, lo) - lo
            if msb < 0 or lsb > 15:
                continue
        else:
            msb, lsb = p.msb, p.lsb
        for bit in range(lsb, msb + 1):
            cells[15 - bit] = p
        bases[p.name] = base
        names.append((-msb, p.name + part))
    text = ""
    i = 0
    while i < 16:
        owner = cells[i]
        if owner is None:
            text += "   |"
            i += 1
            continue
        j = i
        while j + 1 < 16 and cells[j + 1] is owner:
            j += 1
        p = owner
        msw, lsw = p.word_indices(bases[p.name]) * (3 - p.words)
        starts = p.words == 1 or word == msw or p.msb < 16
        ends = p.words == 1 or word == lsw or p.lsb >= 16
        width = 4 * (j - i + 1) - 1
        if width == 3 and starts and ends:
            body = " x "
        else:
            body = ("<" if starts else "-") + "-" * (width - 2) + ("x" if ends else "-")
        text += body + "|"
        i = j + 1
    label = f"{word:>6} |"
    return (label + text + " " + ", ".join(name for _, name in sorted(names))).rstrip()


def _table(m: Message) -> list[str]:
    header = (f"  {'parameter':<24}{'word':>5} {'bits':>6}  {'type':<13}{'lsb':>12} "
              f"{'offset':>8}  {'unit':<7}{'min':>10}{'max':>10}")
    out = [header]
    g = m.group
    rows = [(p, False) for p in m.parameters] + [(c, True) for c in (g.channels if g else ())]
    for p, in_group in rows:
        word = f"+{p.word}" if in_group else str(p.word)
        if p.words == 2:
            word += f"-{'+' if in_group else ''}{p.word + 1}"
        bits = f"{p.msb}-{p.lsb}" if p.msb != p.lsb else str(p.msb)
        kind = str(p.type) + ("/lsw" if p.words == 2 and p.word_order.value == "lsw_first"
                              else "")
        scaled = p.type not in (ParamType.DISCRETE, ParamType.ENUM, ParamType.COUNTER)
        lsb = f"{p.scale:.6g}" if scaled else ""
        offset = f"{p.offset:g}" if scaled else ""
        lo = "" if p.minimum is None else f"{p.minimum:g}"
        hi = "" if p.maximum is None else f"{p.maximum:g}"
        out.append(f"  {p.name:<24}{word:>5} {bits:>6}  {kind:<13}{lsb:>12} {offset:>8}  "
                   f"{p.unit:<7}{lo:>10}{hi:>10}".rstrip())
        if p.labels:
            out.append("      " + " ".join(f"{c}={v}" for c, v in sorted(p.labels.items())))
    if g is not None:
        period = 1e3 / g.sample_rate_hz
        counter = f", block counter {g.counter}" if g.counter else ""
        out.append(f"  group: {g.samples} samples x {g.stride} words from word {g.start}, "
                   f"{g.sample_rate_hz:g} Hz ({period:g} ms){counter}; "
                   f"+n = word n of each sample")
    return out
