"""Fuzz the Chapter 10 reader: damaged copies of a recording, counted by outcome.

    python bench/chapter10_fuzz.py [FILE.c10] [--cases 2000] [--seed N] [--case-timeout 10]

Each case applies one random damage (:mod:`mapr_daemon.testbed.c10damage`: any primary header
field rewritten, lengths and sync included, with a valid header checksum (or the checksum
itself); a 1553 body field rewritten: the channel-specific word, a message's time stamp,
block status, gap word or length; a flipped byte, a zeroed run, a cut) to the file and reads it
to the end twice: with :class:`~drivers.chapter10.reader.Chapter10Reader` (what ``mapr decode``
and ``mapr replay`` use) and through the daemon's ``chapter10`` backend. Counted: reads that
raised (a traceback for the user), reads that did not finish within ``--case-timeout``
seconds (a hang), reads that lost a packet the damage did not touch (its 1553 messages
missing or changed; for the backend: an intact packet's message missing), reads that found no
packet at all (exit 2, correct only when the damage hit the first header or cut the file
before it). Without FILE, a recording the project's own writer makes is used. Without
``--seed``, a fresh seed is drawn and printed.
"""

from __future__ import annotations

import argparse
import collections
import logging
import random
import signal
import sys
import tempfile
import time
import traceback
from pathlib import Path

from seeds import fresh as fresh_seed

from drivers.chapter10.reader import Chapter10Reader
from drivers.errors import CaptureFormatError
from drivers.monitor import open_monitor
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


class Hang(Exception):
    """A read that did not finish within the case time-out."""


def _alarm(signum: int, frame: object) -> None:
    raise Hang


def backend_messages(path: Path) -> collections.Counter[tuple[int, tuple[int, ...],
                                                              tuple[int, ...]]]:
    """Every message the daemon's ``chapter10`` backend replays from the file."""
    got: collections.Counter[tuple[int, tuple[int, ...], tuple[int, ...]]] = \
        collections.Counter()
    with open_monitor("chapter10", path=str(path)) as monitor:
        for record in monitor:
            got[record.command, record.data, record.status] += 1
    return got


def check(data: bytes, spans: list[PacketSpan], reference: Messages, damage: Damage,
          work: Path, timeout_s: float) -> tuple[str, str]:
    """The outcomes of one damaged read by the reader and by the backend: ok, raised, hang,
    lost or empty."""
    work.write_bytes(damage.apply(data))
    intact = [s for s in intact_packets(spans, damage) if s.offset in reference]
    outcomes = []
    for reader in ("reader", "backend"):
        signal.setitimer(signal.ITIMER_REAL, timeout_s)
        try:
            if reader == "reader":
                got, _ = messages_by_packet(work)
                lost = any(got.get(s.offset) != reference[s.offset] for s in intact)
            else:
                replayed = backend_messages(work)
                wanted = collections.Counter(m for s in intact for m in reference[s.offset])
                lost = bool(wanted - replayed)
            outcomes.append("lost" if lost else "ok")
        except Hang:
            outcomes.append("hang")
        except CaptureFormatError:  # no valid header at all: right only when none was left
            outcomes.append("lost" if intact else "empty")
        except Exception:  # the campaign counts what a user would see as a traceback
            traceback.print_exc(limit=3, file=sys.stderr)
            outcomes.append("raised")
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
    return outcomes[0], outcomes[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", type=Path)
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--case-timeout", type=float, default=10.0)
    args = parser.parse_args()
    seed = fresh_seed(args.seed)
    signal.signal(signal.SIGALRM, _alarm)
    logging.disable(logging.WARNING)  # the backend logs each skipped packet; counted here
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
        rng = random.Random(seed)
        outcomes = {"reader": collections.Counter[str](), "backend": collections.Counter[str]()}
        by_kind: collections.Counter[tuple[str, str, str]] = collections.Counter()
        start = time.perf_counter()
        for _ in range(args.cases):
            damage = random_damage(data, spans, rng)
            results = check(data, spans, reference, damage, Path(tmp) / "damaged.c10",
                            args.case_timeout)
            kind = damage.kind if damage.kind not in ("field", "body") else \
                f"{damage.kind}:{damage.field}"
            for reader, outcome in zip(("reader", "backend"), results, strict=True):
                outcomes[reader][outcome] += 1
                by_kind[reader, kind, outcome] += 1
        elapsed = time.perf_counter() - start
    kinds = sorted({kind for _, kind, _ in by_kind})
    print(f"seed {seed}, {args.cases} cases in {elapsed:.1f} s; damage kinds: {', '.join(kinds)}")
    for reader, counts in outcomes.items():
        print(f"  {reader}: " + ", ".join(f"{k} {counts[k]}"
                                          for k in ("ok", "empty", "raised", "hang", "lost")))
    for (reader, kind, outcome), n in sorted(by_kind.items()):
        if outcome in ("raised", "hang", "lost"):
            print(f"  {reader} {kind}: {outcome} {n}")
    bad = sum(c[k] for c in outcomes.values() for k in ("raised", "hang", "lost"))
    return 1 if bad else 0

if __name__ == "__main__":
    sys.exit(main())
