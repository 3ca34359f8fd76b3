"""Message assembler throughput: words per second into MonitorRecords.

    python bench/assembler.py [--seconds 2]

Builds the word stream of a fully loaded bus (no idle time beyond the standard's gaps): a
rotating mix of 32-word BC-to-RT transfers, 16-word RT-to-BC transfers, RT-to-RT transfers,
mode codes with and without data, broadcasts and a no-response, and feeds it to the
assembler in 50 000-word batches, as a decoder would. Prints words/s (best of three) and the
real-time factor against the bus's own word rate. Target: >= 1 M words/s.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.wordbatch import empty_words
from drivers.mil1553.words import CommandWord, StatusWord

WORD = 20_000


def loaded_bus(seconds: float, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows: list[tuple[int, int, int]] = []
    t = 0

    def put(sync: int, value: int, idle_ns: int = 0) -> None:
        nonlocal t
        t += idle_ns
        rows.append((t, sync, value))
        t += WORD

    def data(n: int) -> None:
        for v in rng.integers(0, 65536, n):
            put(0, int(v))

    response, gap = 6_000, 4_000
    kind = 0
    while t < seconds * 1e9:
        kind = (kind + 1) % 6
        if kind == 0:
            put(1, CommandWord(5, False, 1, 0).value, gap)
            data(32)
            put(1, StatusWord(5).value, response)
        elif kind == 1:
            put(1, CommandWord(6, True, 2, 16).value, gap)
            put(1, StatusWord(6).value, response)
            data(16)
        elif kind == 2:
            put(1, CommandWord(7, False, 3, 8).value, gap)
            put(1, CommandWord(6, True, 3, 8).value)
            put(1, StatusWord(6).value, response)
            data(8)
            put(1, StatusWord(7).value, response)
        elif kind == 3:
            put(1, CommandWord(5, True, 31, 19).value, gap)
            put(1, StatusWord(5).value, response)
            data(1)
        elif kind == 4:
            put(1, CommandWord(31, False, 4, 4).value, gap)
            data(4)
        else:
            put(1, CommandWord(9, False, 1, 2).value, gap)
            data(2)
            t += 14_000  # the BC waits out the no-response time-out
    words = empty_words(len(rows))
    table = np.array(rows, dtype=np.int64)
    words["t_ns"], words["sync"], words["value"] = table[:, 0], table[:, 1], table[:, 2]
    words["end_ns"] = words["t_ns"] + 19_500
    return words


def run_once(words: np.ndarray, batch: int = 50_000) -> tuple[float, int, int]:
    start = time.perf_counter()
    assembler = MessageAssembler()
    records = []
    for s in range(0, words.size, batch):
        records += assembler.feed(words[s:s + batch])
    records += assembler.flush()
    errors = sum(1 for r in records if r.errors and r.errors != ("no_response",))
    return time.perf_counter() - start, len(records), errors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="bus time to assemble")
    args = parser.parse_args()
    words = loaded_bus(args.seconds)
    results = [run_once(words) for _ in range(3)]
    elapsed, messages, unexpected = min(results)
    rate = words.size / elapsed
    bus_rate = words.size / args.seconds
    print(f"{words.size} words, {messages} messages from {args.seconds:g} s of loaded bus "
          f"({bus_rate / 1e3:.1f} k words/s on the bus)")
    print(f"assembler: {rate / 1e6:.2f} M words/s = {rate / bus_rate:.0f}x real time "
          f"(target >= 1 M words/s); unexpected errors: {unexpected}")


if __name__ == "__main__":
    main()
