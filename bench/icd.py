"""Decode throughput of the message table: data words per second through the signal stream.

Builds ``--seconds`` of the EMA testbed schedule's traffic with the table's own encoder (a
test pattern in every parameter), then times one pass of :class:`SignalStream` over it in
chunks, as the daemon would run it: grouping by RT/SA, stacking the data words and pulling
every parameter out with numpy, block counters and sample timing included. Prints one line.
Target: >= 1 M words/s (the bus itself carries at most 50 k words/s).

    python3 bench/icd.py [--seconds 30] [--chunk 4096] [--table configs/icd/ema-testbed.yaml]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from mapr_daemon.icd import load_icd
from mapr_daemon.icd.signals import SignalStream
from mapr_daemon.icd.traffic import pattern_values, schedule_records

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=int, default=30, help="seconds of bus traffic")
    parser.add_argument("--chunk", type=int, default=4096, help="records per decode batch")
    parser.add_argument("--table", default=str(REPO / "configs/icd/ema-testbed.yaml"))
    args = parser.parse_args()

    icd = load_icd(args.table)
    assert icd.schedule is not None
    frames = round(args.seconds * 1e6 / icd.schedule.minor_frame_us)
    records = list(schedule_records(icd, pattern_values, frames=frames))

    stream = SignalStream(icd, chunk=args.chunk)
    start = time.perf_counter()
    samples = 0
    for chunk in stream.stream(records):
        samples += sum(len(s) for s in chunk.values())
    elapsed = time.perf_counter() - start

    words = stream.stats.data_words
    assert stream.stats.lost_blocks == stream.stats.repeated_blocks == 0
    print(f"icd decode ({Path(args.table).name}, {args.seconds} s of traffic): "
          f"{words} data words in {len(records)} records -> {samples} samples in "
          f"{elapsed:.3f} s = {words / elapsed / 1e6:.2f} M words/s (target >= 1 M words/s)")


if __name__ == "__main__":
    main()
