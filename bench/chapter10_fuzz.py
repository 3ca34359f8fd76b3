"""Fuzz the Chapter 10 reader: damaged copies of a recording, counted by outcome.

    python bench/chapter10_fuzz.py [FILE.c10] [--cases 2000] [--seed 1]

Each case applies one random damage (:mod:`mapr_daemon.testbed.c10damage`: a header field
rewritten with a valid header checksum, a flipped byte, a zeroed run, a cut) to the file and
reads it to the end with :class:`~drivers.chapter10.reader.Chapter10Reader`. Counted: reads
that raised (a traceback for the user), reads that lost a packet the damage did not touch
(its 1553 messages missing or changed), reads that found no packet at all (exit 2, correct
only when the damage hit the first header or cut the file before it). Without FILE, a
recording the project's own writer makes is used.
"""

from __future__ import annotations

import argparse
import collections
import random
import sys
import tempfile
import time
import traceback
from pathlib import Path

from drivers.chapter10.reader import Chapter10Reader
from drivers.errors import CaptureFormatError
from mapr_daemon.testbed.c10damage import (
    Damage,
    PacketSpan,
    intact_packets,
    many_packet_recording,
    packet_spans,
    random_damage,
)

Messages = dict[int, list[tuple[int, tuple[int, ...], tuple[int, ...]]]]


def messages_by_packet(path: Path) -> tuple[Messages, list[str]]:
    """Each 1553 packet's messages (command, data, status) by file offset, and the issues."""
    reader = Chapter10Reader(path)
    out: Messages = {}
    try:
        for batch in reader:
            if batch.records:
                out[batch.offset] = [(r.command, r.data, r.status) for r in batch.records]
    finally:
        reader.close()
    return out, [str(i) for i in reader.issues]


def check(data: bytes, spans: list[PacketSpan], reference: Messages, damage: Damage,
          work: Path) -> str:
    """The outcome of one damaged read: ok, raised, lost or empty."""
    work.write_bytes(damage.apply(data))
    try:
        got, _ = messages_by_packet(work)
    except CaptureFormatError:  # no valid header at all: right only when none was left
        return "lost" if intact_packets(spans, damage) else "empty"
    except Exception:  # the campaign counts what a user would see as a traceback
        traceback.print_exc(limit=3, file=sys.stderr)
        return "raised"
    for span in intact_packets(spans, damage):
        if span.offset in reference and got.get(span.offset) != reference[span.offset]:
            return "lost"
    return "ok"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", type=Path)
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        source = args.file
        if source is None:
            source = Path(tmp) / "written.c10"
            many_packet_recording(source)
        data = source.read_bytes()
        spans = packet_spans(data)
        reference, issues = messages_by_packet(source)
        print(f"{source.name}: {len(data)} bytes, {len(spans)} packets, "
              f"{len(reference)} with 1553 messages, {len(issues)} issues undamaged")
        rng = random.Random(args.seed)
        outcomes: collections.Counter[str] = collections.Counter()
        by_kind: collections.Counter[tuple[str, str]] = collections.Counter()
        start = time.perf_counter()
        for _ in range(args.cases):
            damage = random_damage(data, spans, rng)
            outcome = check(data, spans, reference, damage, Path(tmp) / "damaged.c10")
            outcomes[outcome] += 1
            by_kind[damage.kind if damage.kind != "field" else damage.field, outcome] += 1
        elapsed = time.perf_counter() - start
    print(f"seed {args.seed}, {args.cases} cases in {elapsed:.1f} s: " +
          ", ".join(f"{k} {outcomes[k]}" for k in ("ok", "empty", "raised", "lost")))
    for (kind, outcome), n in sorted(by_kind.items()):
        if outcome in ("raised", "lost"):
            print(f"  {kind}: {outcome} {n}")
    return 1 if outcomes["raised"] or outcomes["lost"] else 0


if __name__ == "__main__":
    sys.exit(main())
