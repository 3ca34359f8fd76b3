"""``mapr encode``: write a capture from a JSON-lines word list, with impairments and faults.

Each input line is one word::

    {"t_ns": 1000, "bus": "A", "sync": "cmd", "value": 10274}
    {"t_ns": 21000, "bus": "A", "sync": "data", "value": 21845, "fault": {"parity": true}}

``fault`` may hold ``parity`` (bool), ``no_transition`` (bit 0-16), ``bit_count`` (bits added
or, if negative, removed) and ``inverted_sync`` (bool). A bad line gives one error naming the
file and line, and exit code 2. The output is a raw capture, or a sigrok session if the name
ends in ``.sr``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from drivers.capturefile import parse_samplerate, write_raw, write_sigrok
from drivers.errors import CaptureFormatError, EncodeError
from drivers.mil1553.encoder import Impairments, WordFault, encode_words
from drivers.mil1553.wordbatch import BUS_NAMES, SYNC_NAMES, WordBatch, empty_words
from mapr_daemon.cli import exitcodes


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "encode", help="write a bit-level capture from a JSON-lines word list",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("words", help="JSON-lines word list, '-' for stdin")
    parser.add_argument("-o", "--output", required=True, help="capture to write (.sr = sigrok)")
    parser.add_argument("--samplerate", type=parse_samplerate, default=10e6, metavar="HZ")
    parser.add_argument("--jitter-ns", type=float, default=0.0,
                        help="zero-crossing deviation, uniform in +/- this")
    parser.add_argument("--dead-band-ns", type=float, default=0.0,
                        help="both receiver outputs low for this long around each crossing")
    parser.add_argument("--rate-error", type=float, default=0.0,
                        help="fractional bit-rate error, e.g. 1e-3 for 0.1%% slow")
    parser.add_argument("--glitch-probability", type=float, default=0.0,
                        help="chance per word of one single-sample glitch")
    parser.add_argument("--seed", type=int, default=0)
    parser.set_defaults(func=run)


def read_word_list(path: str) -> tuple[WordBatch, list[WordFault]]:
    """Parse a JSON-lines word list; errors name the file and line."""
    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise CaptureFormatError(f"{path}: {getattr(error, 'strerror', None) or error}") from error
    rows: list[tuple[int, int, int, int]] = []
    faults: list[WordFault] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            item = json.loads(line)
            bus = BUS_NAMES.index(str(item.get("bus", "A")).upper())
            sync = SYNC_NAMES.index(str(item["sync"]))
            value = int(item["value"])
            if not 0 <= value <= 0xFFFF:
                raise ValueError(f"value {value} is not a 16-bit word")
            rows.append((int(item["t_ns"]), bus, sync, value))
            faults.append(WordFault(**item.get("fault", {})))
        except (json.JSONDecodeError, KeyError, ValueError, TypeError, EncodeError) as error:
            detail = f"missing field {error}" if isinstance(error, KeyError) else str(error)
            raise CaptureFormatError(f"{path}:{number}: {detail}") from error
    words = empty_words(len(rows))
    if rows:
        table = np.array(rows, dtype=np.int64)
        for column, name in enumerate(("t_ns", "bus", "sync", "value")):
            words[name] = table[:, column]
    return words, faults


def run(args: argparse.Namespace) -> int:
    words, faults = read_word_list(args.words)
    impairments = Impairments(rate_error=args.rate_error, jitter_ns=args.jitter_ns,
                              dead_band_ns=args.dead_band_ns,
                              glitch_probability=args.glitch_probability, seed=args.seed)
    samples = encode_words(words, args.samplerate, impairments=impairments, faults=faults)
    try:
        if str(args.output).endswith(".sr"):
            write_sigrok(args.output, samples, args.samplerate)
        else:
            write_raw(args.output, samples)
    except OSError as error:
        raise CaptureFormatError(f"{args.output}: {error.strerror or error}") from error
    print(f"{args.output}: {len(words)} words, {samples.size} samples at "
          f"{args.samplerate / 1e6:g} MS/s", file=sys.stderr)
    return exitcodes.OK
