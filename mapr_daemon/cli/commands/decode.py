"""``mapr decode``: decode a capture file and print JSON lines, one per message.

    {"t_ns": 1997, "bus": "A", "format": "BC_RT", "rt": 5, "tr": "R", "sa": 1, "wc": 2,
     "data": [32768, 32767], "status": [10240], "gaps_ns": [7953], "errors": []}

``t_ns`` is the leading edge of the first command word's sync; for RT-RT, ``rt``/``sa`` are
the receiving terminal's and ``rt2``/``sa2`` the transmitting one's; ``data`` and ``status``
list words in bus order; ``gaps_ns`` are response gaps, mid-crossing to mid-crossing.
With ``--icd FILE`` each message the table describes also carries ``"values"`` (engineering
values, and ``"flags"`` for values out of range). With ``--words``, one object per word as
the codec sees it: ``{"t_ns", "bus", "sync", "value", "errors"}``.

A truncated capture decodes what is there; the word cut by the end is flagged. A file that
cannot be read gives one line on stderr and exit code 2; an invalid ICD, exit code 78.

A Chapter 10 recording (found by its packet sync pattern, whatever its name) prints its 1553
messages the same way, plus ``channel`` and ``time``, and its ARINC 429 words as lines with
``"kind": "arinc429"`` (see docs/chapter10.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any, TextIO

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic import chapter10_decode
from mapr_daemon.cli.traffic.source import positive_seconds
from mapr_daemon.cli.validate import add_filter_arguments

if TYPE_CHECKING:
    from drivers.mil1553.record import MonitorRecord
    from drivers.mil1553.wordbatch import WordBatch


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "decode", help="decode a bit-level capture (raw or sigrok .sr) or a Chapter 10 "
                       "recording to JSON lines",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("capture", help="raw capture file, '-' for stdin, a sigrok .sr file "
                                        "or a Chapter 10 recording")
    parser.add_argument("--samplerate", type=_rate, default=None, metavar="HZ",
                        help="sample rate of a raw capture, e.g. 10e6 or 10MHz "
                             "(read from the metadata of a .sr file)")
    parser.add_argument("--channels", type=_channels, default=None,
                        metavar="A_RX,A_RXB,B_RX,B_RXB",
                        help="the .sr channel names holding our four receiver outputs")
    parser.add_argument("--words", action="store_true",
                        help="print one JSON object per word (the codec's output)")
    parser.add_argument("--icd", metavar="FILE", help="message table: add engineering values")
    parser.add_argument("--stats", nargs="?", const="text", choices=["text", "json"],
                        help="print per-RT/SA statistics and windowed bus load of the "
                             "messages the filters keep, instead of the messages: a table "
                             "(default; also with --text) or JSON lines")
    parser.add_argument("--stats-window", type=positive_seconds, default=1.0, metavar="S",
                        help="bus-load window for --stats, in seconds (default 1)")
    parser.add_argument("--text", action="store_true",
                        help="aligned columns for people (time, bus, RT-SA, T/R, wc, status, "
                             "data in hex, errors) instead of JSON lines")
    add_filter_arguments(parser)
    chapter10_decode.add_arguments(parser)
    parser.set_defaults(func=run, validate=validate)


def validate(args: argparse.Namespace) -> str | None:
    """Flags that contradict each other, or a filter value that is malformed or can never
    match, as one line (exit 2 before the file is read)."""
    if args.stats == "json" and args.text:
        return "--stats json and --text ask for two formats; --stats alone prints the table"
    from mapr_daemon.cli.traffic.decode_filter import filter_problem

    return filter_problem(args)


def _rate(text: str) -> float:
    from drivers.capturefile import parse_samplerate
    try:
        return parse_samplerate(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from error


def _channels(text: str) -> list[str]:
    return [part.strip() for part in text.split(",")]


def run(args: argparse.Namespace) -> int:
    if args.stats:
        from mapr_daemon.cli.traffic.source import run_decode_stats

        return run_decode_stats(args)

    # imported here, not at the top, so that `mapr decode --help` starts at once; the
    # bit-level decoder (numba kernels) only for a capture, not for a Chapter 10 file
    from mapr_daemon.cli.icdview.view import IcdView
    from mapr_daemon.cli.traffic.decode_filter import FilterError, filter_from_args
    from mapr_daemon.cli.traffic.source import chapter10_input

    try:
        wanted = filter_from_args(args)
    except FilterError as error:
        print(f"mapr decode: {error}", file=sys.stderr)
        return exitcodes.USAGE
    if args.words and (wanted.active or args.text):
        print("mapr decode: --words prints every word; filters and --text apply to messages",
              file=sys.stderr)
        return exitcodes.USAGE
    if args.text and args.icd:
        print("mapr decode: --text does not show --icd values; use the JSON lines",
              file=sys.stderr)
        return exitcodes.USAGE
    view = IcdView(args.icd)
    found = chapter10_input(args.capture)
    if found is not None:
        return chapter10_decode.decode_chapter10(args, view, wanted, source=found)
    from drivers.backends.capture import check_capture_file
    from drivers.capturefile import open_capture
    from drivers.errors import CaptureFormatError
    from drivers.pipeline import SamplePipeline
    from mapr_daemon.cli.traffic.render import record_json
    check_capture_file(args.capture, args.samplerate, rate_hint="--samplerate HZ")
    from mapr_daemon.cli.traffic.decode_text import HEADER, record_text
    source = open_capture(args.capture, args.samplerate, args.channels)
    pipeline = SamplePipeline(source.sample_rate)
    out = sys.stdout

    if args.text:
        out.write(HEADER)

    def emit(records: list[MonitorRecord]) -> None:
        if args.words:
            _print_words(pipeline.last_words, out)
            return
        if wanted.active:
            records = [r for r in records if wanted.matches(r)]
        for record in records:
            if args.text:
                out.write(record_text(record))
            else:
                out.write(record_json(record, view.values(record)) + "\n")

    try:
        for chunk in source.chunks:
            emit(pipeline.feed(chunk))
    except BrokenPipeError:
        raise  # the reader went away (`| head`): not a read error
    except (OSError, ValueError) as error:
        # A read error mid-file: keep what was decoded, say what went wrong.
        emit(pipeline.flush())
        raise CaptureFormatError(f"{source.name}: read failed: {error}") from error
    emit(pipeline.flush())
    out.flush()
    return exitcodes.OK


def _print_words(words: WordBatch, out: TextIO) -> None:
    from drivers.mil1553.wordbatch import word_to_json
    for row in words:
        out.write(json.dumps(word_to_json(row)) + "\n")
