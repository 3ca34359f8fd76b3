"""``mapr decode --text``: one aligned line per message, as a bus analyzer lists traffic.

::

          time_s bus format             RT-SA       T/R  wc status    data / errors
        0.348735  A  BC_RT              13-08        R    1 6800      326C
        0.001064  A  RT_RT              05-03<06-03  R    8 3000 2800 0000 0001 0002 ...
        0.001324  B  MODE               05-00        T  m02 2800

``time_s``: the message's start in seconds of bus time; ``RT-SA``: the command's terminal and
subaddress (for RT-RT, in bus order as every text view writes it: the receiver's, then ``<``,
"receives from", and the transmitter's); ``wc``: the word
count the command calls for, or ``mNN`` for a mode code; ``status`` and ``data`` in hex, in
bus order; errors after ``!``.
"""

from __future__ import annotations

from drivers.chapter10.ms1553_batch import FORMATS, Ms1553Batch, error_names
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.words import MODE_SUBADDRESSES

HEADER = f"{'time_s':>12} bus {'format':<18} {'RT-SA':<11} T/R {'wc':>3} {'status':<9} " \
         "data / errors\n"
CHANNEL_HEADER = f"{'time_s':>12} {'ch':>5} bus {'format':<18} {'RT-SA':<11} T/R {'wc':>3} " \
                 f"{'status':<9} data / errors\n"
"""The header of a Chapter 10 recording's lines: ``ch``, the channel ID, after the time
(each 1553 channel is a bus of its own; a capture has one, and no column)."""
_HEX = [f"{i:04X}" for i in range(1 << 16)]


def _row(t_ns: int, bus: str, fmt: str, command: int, command2: int, status: list[int],
         data: list[int], errors: tuple[str, ...]) -> str:
    rt, sa = command >> 11 & 31, command >> 5 & 31
    where = f"{rt:02d}-{sa:02d}"
    if command2 >= 0:
        where += f"<{command2 >> 11 & 31:02d}-{command2 >> 5 & 31:02d}"
    count = f"m{command & 31:02d}" if sa in MODE_SUBADDRESSES else str((command & 31) or 32)
    tr = "T" if command >> 10 & 1 else "R"
    line = (f"{t_ns / 1e9:12.6f}  {bus}  {fmt:<18} {where:<11}  {tr}  {count:>3} "
            f"{' '.join(_HEX[s] for s in status):<9} {' '.join(_HEX[d] for d in data)}")
    if errors:
        line += " ! " + ",".join(errors)
    return line.rstrip() + "\n"


def text_lines(batch: Ms1553Batch, *, channel: bool = False) -> list[str]:
    """The batch's messages, one line each (``channel``: with the channel column of
    :data:`CHANNEL_HEADER` after the time)."""
    words = batch.words.tolist()
    kept = batch.n_status.tolist()
    if channel:
        return [f"{line[:12]} {ch:>5}{line[12:]}" for line, ch in zip(
            text_lines(batch), batch.channel.tolist(), strict=True)]
    return [_row(t, "B" if bus else "A", str(FORMATS[fmt]), cmd, cmd2, status[:k],
                 words[start:start + count], error_names(errors))
            for t, bus, fmt, cmd, cmd2, status, k, start, count, errors in zip(
                batch.t_ns.tolist(), batch.bus.tolist(), batch.format.tolist(),
                batch.command.tolist(), batch.command2.tolist(), batch.status.tolist(), kept,
                batch.data_start.tolist(), batch.data_count.tolist(), batch.errors.tolist(),
                strict=True)]


def record_text(record: MonitorRecord) -> str:
    """One record (a bit-level capture's), one line; a stray word has no command."""
    if record.command is None:
        line = (f"{record.t_ns / 1e9:12.6f}  {record.bus}  {record.format!s:<18} {'-':<11}  "
                f"-  {'-':>3} {'':<9} {' '.join(_HEX[d] for d in record.data)}")
        if record.errors:
            line += " ! " + ",".join(record.errors)
        return line.rstrip() + "\n"
    return _row(record.t_ns, record.bus, str(record.format), record.command,
                -1 if record.command2 is None else record.command2, list(record.status),
                list(record.data), record.errors)
