"""``mapr decode``: decode a capture file and print JSON lines.

With ``--words``, one object per word, as the codec sees it::

    {"t_ns": 1000, "bus": "A", "sync": "cmd", "value": 10274, "errors": []}

A truncated capture decodes what is there; the word cut by the end is flagged. A file that
cannot be read gives one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from drivers.capturefile import open_capture
from drivers.errors import CaptureFormatError
from drivers.mil1553.decoder import ManchesterDecoder
from drivers.mil1553.wordbatch import WordBatch, word_to_json
from mapr_daemon.cli import exitcodes


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "decode", help="decode a bit-level capture (raw or sigrok .sr) to JSON lines",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("capture", help="raw capture file, '-' for stdin, or a sigrok .sr file")
    parser.add_argument("--samplerate", type=_rate, default=None, metavar="HZ",
                        help="sample rate of a raw capture, e.g. 10e6 or 10MHz "
                             "(read from the metadata of a .sr file)")
    parser.add_argument("--channels", type=_channels, default=None,
                        metavar="A_RX,A_RXB,B_RX,B_RXB",
                        help="the .sr channel names holding our four receiver outputs")
    parser.add_argument("--words", action="store_true",
                        help="print one JSON object per word (the codec's output)")
    parser.set_defaults(func=run)


def _rate(text: str) -> float:
    from drivers.capturefile import parse_samplerate
    try:
        return parse_samplerate(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from error


def _channels(text: str) -> list[str]:
    return [part.strip() for part in text.split(",")]


def run(args: argparse.Namespace) -> int:
    if not args.words:
        print("mapr decode: message-level decoding comes with the bus monitor; "
              "use --words for the word level", file=sys.stderr)
        return exitcodes.USAGE
    source = open_capture(args.capture, args.samplerate, args.channels)
    decoder = ManchesterDecoder(source.sample_rate)
    out = sys.stdout
    try:
        for chunk in source.chunks:
            _print_words(decoder.feed(chunk), out)
    except (OSError, ValueError) as error:
        # A read error mid-file: keep what was decoded, say what went wrong.
        _print_words(decoder.flush(), out)
        raise CaptureFormatError(f"{source.name}: read failed: {error}") from error
    _print_words(decoder.flush(), out)
    out.flush()
    return exitcodes.OK


def _print_words(words: WordBatch, out: Any) -> None:
    for row in words:
        out.write(json.dumps(word_to_json(row)) + "\n")
