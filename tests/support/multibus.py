"""A Chapter 10 recording of several 1553 buses, written with the project's own packet writer.

Each channel is one bus carrying the same schedule, as a recorder of eight identical buses
(or of a bus pair per aircraft) writes them: on every channel, at :data:`RATE_HZ`,

* RT 5 sends 4 words to the bus controller from SA 2 (``05-02`` T, RT->BC);
* the BC sends 2 words to RT 6 SA 1 (``06-01`` R, BC->RT);
* RT 6 sends 3 words from its SA 3 to RT 5 SA 4 (``05-04<06-03``, RT->RT).

The packets of the channels are interleaved, each holding :data:`PER_PACKET` messages of one
channel, after a TMATS and a time packet, as :mod:`drivers.chapter10.recording_packets`
lays them out. The words of each channel differ (word 0 of every message is its channel ID),
so a test can tell the buses apart.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from drivers.chapter10.recording_packets import ms1553_packet, time_packet, tmats_packet
from drivers.mil1553.record import MonitorRecord, TransferFormat

RATE_HZ = 450
"""Each message's rate on each bus."""
SECONDS = 1
"""The recording's length."""
PER_PACKET = 3 * 45
"""Messages per 1553 packet (100 ms of one bus)."""
TIME_CHANNEL = 100
"""The time packet's channel ID."""


def _command(rt: int, tr: int, sa: int, wc: int) -> int:
    return rt << 11 | tr << 10 | sa << 5 | (wc & 31)


def bus_records(channel: int) -> list[MonitorRecord]:
    """One bus's traffic for :data:`SECONDS`, in time order (see the module docstring)."""
    period = 1_000_000_000 // RATE_HZ
    out = []
    for i in range(RATE_HZ * SECONDS):
        t = i * period + channel * 1000
        out.append(MonitorRecord(
            t_ns=t, bus="A", format=TransferFormat.RT_BC, command=_command(5, 1, 2, 4),
            data=(channel, i & 0xFFFF, 2, 3), status=(5 << 11,), gaps_ns=(8000,),
            end_ns=t + 6 * 20_000))
        t += 200_000
        out.append(MonitorRecord(
            t_ns=t, bus="A", format=TransferFormat.BC_RT, command=_command(6, 0, 1, 2),
            data=(channel, 7), status=(6 << 11,), gaps_ns=(8000,), end_ns=t + 4 * 20_000))
        t += 200_000
        out.append(MonitorRecord(
            t_ns=t, bus="B", format=TransferFormat.RT_RT, command=_command(5, 0, 4, 3),
            command2=_command(6, 1, 3, 3), data=(channel, 8, 9), status=(6 << 11, 5 << 11),
            gaps_ns=(8000, 8000), end_ns=t + 7 * 20_000))
    return out


def packets(channels: list[int]) -> list[bytes]:
    """TMATS, a time packet, then each channel's 1553 packets interleaved."""
    out = [tmats_packet(0, "G\\DSI\\N:0;", 1),
           time_packet(TIME_CHANNEL, 0, 0, datetime(2024, 5, 1, 12, 0, 0))]
    records = {c: bus_records(c) for c in channels}
    total = len(next(iter(records.values()))) if records else 0
    for sequence, start in enumerate(range(0, total, PER_PACKET)):
        for c in channels:
            out.append(ms1553_packet(c, sequence, records[c][start:start + PER_PACKET]))
    return out


def write_recording(path: Path, channels: list[int]) -> Path:
    """Write the recording of ``channels`` (one bus each) to ``path``; return ``path``."""
    path.write_bytes(b"".join(packets(channels)))
    return path
