"""Chapter 10 recording throughput: MonitorRecords per second into a Chapter 10 file.

    python bench/recording.py [--seconds 5]

Two fully loaded buses' worth of records (no idle time beyond the standard's gaps) go through
:class:`~drivers.chapter10.writer.Chapter10Writer` to a temporary file: the worst case for a
per-message writer, back-to-back mode codes without data (cmd, 8 µs response gap, status;
about 19,200 messages per second of bus), and a mix of 32-word BC-to-RT, 16-word RT-to-BC,
8-word RT-to-RT and mode-code messages. Prints messages/s (best of three), the real-time factor
against the bus time the records cover, and the load average (the machine is shared).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from datetime import datetime
from pathlib import Path

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.mil1553.words import CommandWord, StatusWord

WORD_NS = 20_000
GAP_NS = 4_000
RESPONSE_NS = 8_000


def mode_codes(seconds: float) -> list[MonitorRecord]:
    """Back-to-back "transmit status word" mode codes: the most messages a bus can carry."""
    command, status = CommandWord(5, True, 0, 2).value, StatusWord(5).value
    step = GAP_NS + WORD_NS + RESPONSE_NS + WORD_NS
    return [MonitorRecord(t, "A", TransferFormat.MODE, command, status=(status,),
                          gaps_ns=(RESPONSE_NS,), end_ns=t + step - GAP_NS)
            for t in range(0, int(seconds * 1e9), step)]


def mixed(seconds: float) -> list[MonitorRecord]:
    """A rotating mix of long and short messages on both buses."""
    records: list[MonitorRecord] = []
    t, kind = 0, 0
    status5, status6 = StatusWord(5).value, StatusWord(6).value
    while t < seconds * 1e9:
        bus = "AB"[kind % 2]
        if kind % 4 == 0:
            words = 34
            rec = MonitorRecord(t, bus, TransferFormat.BC_RT, CommandWord(5, False, 1, 0).value,
                                data=tuple(range(32)), status=(status5,),
                                gaps_ns=(RESPONSE_NS,))
        elif kind % 4 == 1:
            words = 18
            rec = MonitorRecord(t, bus, TransferFormat.RT_BC, CommandWord(6, True, 2, 16).value,
                                data=tuple(range(16)), status=(status6,),
                                gaps_ns=(RESPONSE_NS,))
        elif kind % 4 == 2:
            words = 12
            rec = MonitorRecord(t, bus, TransferFormat.RT_RT, CommandWord(5, False, 3, 8).value,
                                command2=CommandWord(6, True, 3, 8).value,
                                data=tuple(range(8)), status=(status6, status5),
                                gaps_ns=(RESPONSE_NS, RESPONSE_NS))
        else:
            words = 2
            rec = MonitorRecord(t, bus, TransferFormat.MODE, CommandWord(5, True, 0, 2).value,
                                status=(status5,), gaps_ns=(RESPONSE_NS,))
        records.append(rec)
        t += GAP_NS + words * WORD_NS + len(rec.gaps_ns) * RESPONSE_NS
        kind += 1
    return records


def best_rate(records: list[MonitorRecord], path: Path) -> float:
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        with Chapter10Writer(path, start_time=datetime(2026, 1, 1)) as writer:
            writer.write(records)
        best = min(best, time.perf_counter() - start)
    return len(records) / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="bus time per case")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.c10"
        for name, records in (("mode codes, back to back", mode_codes(args.seconds)),
                              ("mixed traffic, both buses", mixed(args.seconds))):
            span_s = (records[-1].t_ns - records[0].t_ns) / 1e9
            rate = best_rate(records, path)
            print(f"{name}: {len(records)} messages over {span_s:.1f} s of bus: "
                  f"{rate:,.0f} messages/s, {rate * span_s / len(records):.1f}x real time "
                  f"(load average {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
