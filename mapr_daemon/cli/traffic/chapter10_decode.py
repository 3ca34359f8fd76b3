"""``mapr decode FILE.c10``: a Chapter 10 recording as JSON lines, in file order.

A 1553 message prints as for a capture (:meth:`MonitorRecord.to_json`, plus ``values`` with
``--icd``; written a batch at a time by :mod:`drivers.chapter10.ms1553_json` and
:mod:`mapr_daemon.cli.icdview.batch`, byte for byte the same), with two more keys:
``channel`` (the Chapter 10 channel ID) and, once the file has given a time packet, ``time``
(absolute, ISO 8601). An ARINC 429 word prints as::

    {"t_ns": 362000, "kind": "arinc429", "channel": 9, "bus": 3, "speed": "high",
     "label": "012", "sdi": 0, "data": 2000, "ssm": 3, "word": "0xE01F4050", "errors": []}

With a filter (``--rt``, ``--sa``, ``--tr``, ``--format``, ``--errors``, ``--error``,
``--from``, ``--to``) or ``--text``, only 1553 messages print (filtered as numpy masks on each
batch; see :mod:`.decode_filter` and :mod:`.decode_text`).

Damaged packets are skipped and named on stderr with their file offset; decoding goes on.
With ``--text`` a ``ch`` column gives each message's channel (each 1553 channel is a bus).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, TextIO

from mapr_daemon.cli import exitcodes, notes
from mapr_daemon.cli.traffic.source import Chapter10Input, add_c10_channel_argument, what_it_holds
from mapr_daemon.cli.validate import bounded_int

if TYPE_CHECKING:
    from drivers.chapter10.reader import Chapter10Reader
    from mapr_daemon.cli.icdview.batch import BatchValues
    from mapr_daemon.cli.icdview.view import IcdView
    from mapr_daemon.cli.traffic.decode_filter import DecodeFilter


BATCH_MESSAGES = 32768
"""Messages per batch (the reader's default is 8192): each batch's ICD values cost a dozen
numpy calls per parameter of each ICD message in it with the ``repr`` writer, and a fixed
few calls with the compiled one, whatever its size, so larger batches write ``--icd`` values
faster (bench/chapter10_speed.py's traffic; docs/figures.md); the lines of one batch are held
at once (a few tens of MB at this size)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that apply to Chapter 10 files only."""
    group = parser.add_argument_group("Chapter 10 recordings")
    add_c10_channel_argument(group, "read only this channel ID (repeat for more; default: "
                                    "every 1553 and ARINC 429 channel)")
    group.add_argument("--year", type=bounded_int(1970, 2199, "year"), default=None,
                       help="year of day-of-year time packets (for the absolute 'time')")


def decode_chapter10(args: argparse.Namespace, view: IcdView,
                     wanted: DecodeFilter | None = None, out: TextIO | None = None,
                     err: TextIO | None = None, source: Chapter10Input | None = None) -> int:
    """Print the file's 1553 messages (those ``wanted`` keeps; all by default) and ARINC
    429 words (not with a filter or ``--text``); issues go to ``err``. ``source``: the
    recording as found (a stream spooled, named ``stdin``); default ``args.capture``."""
    out = out or sys.stdout
    err = err or sys.stderr
    if args.words:
        err.write("mapr decode: --words applies to bit-level captures, not to Chapter 10 "
                  f"recordings ({args.capture})\n")
        return exitcodes.USAGE
    from drivers.chapter10.ms1553_json import json_lines
    from drivers.chapter10.reader import Chapter10Reader
    from mapr_daemon.cli.traffic.decode_filter import DecodeFilter
    from mapr_daemon.cli.traffic.decode_text import CHANNEL_HEADER, text_lines
    wanted = wanted or DecodeFilter()
    text = bool(getattr(args, "text", False))
    only_1553 = wanted.active or text
    source = source or Chapter10Input(args.capture, args.capture)
    try:
        reader = Chapter10Reader(source.path, channels=args.c10_channels, year=args.year,
                                 arinc429=not only_1553, name=source.name)
    finally:
        source.done_opening()
    reported = 0
    batch_values: BatchValues | None = None
    if text:
        out.write(CHANNEL_HEADER)
    try:
        for batch in reader.batches(BATCH_MESSAGES):
            messages = batch.ms1553
            if messages is not None and wanted.active:
                messages = messages.take(wanted.mask(messages))
            lines: list[str] = []
            if messages is not None and text:
                lines = text_lines(messages, channel=True)
            elif messages is not None:
                values = None
                if view.icd is not None:   # the table code only when there is a table
                    if batch_values is None:
                        from mapr_daemon.cli.icdview.batch import BatchValues

                        batch_values = BatchValues(view.icd)
                    values = batch_values(messages)
                lines = json_lines(messages, values)
            done = 0
            for place, words in batch.arinc429_at:   # in file order among the messages
                out.write("".join(lines[done:place]))
                out.writelines(json.dumps(word) + "\n" for word in words.to_json())
                done = place
            out.write("".join(lines[done:]))
            if batch.arinc429 is not None:
                for word in batch.arinc429.to_json():
                    out.write(json.dumps(word) + "\n")
            reported = _report(reader, reported, err)
    finally:
        reader.close()
    _report(reader, reported, err)
    out.flush()
    return what_it_holds(reader, args.c10_channels, "mapr decode", err=err,
                         other_data=not only_1553)


def _report(reader: Chapter10Reader, reported: int, err: TextIO) -> int:
    issues = reader.issues
    for issue in issues[reported:]:
        if err is sys.stderr:   # the command's warnings: collapsed, silenced by -q
            notes.warn(f"{reader.name}: {issue}")
        else:
            err.write(f"mapr decode: {reader.name}: {issue}\n")
    return len(issues)
