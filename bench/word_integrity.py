"""The decoder's integrity campaign: no damaged word may come out clean with a wrong value.

    python bench/word_integrity.py [--words 10000000] [--clean-words 10000000]
                                   [--rates 10e6,...,200e6] [--jitter-ns 150]
                                   [--clean-jitter-ns 150,100] [--dead-band-ns 0] [--seed N]

Sends ``--words`` corrupted words, split evenly over every corruption kind of
:mod:`tests.support.corruption` and every sample rate, each word with every zero crossing
displaced by up to ±``--jitter-ns`` (the standard's receiver tolerance), and ``--clean-words``
undamaged words at the lowest rate given (the minimum supported rate) for each jitter of
``--clean-jitter-ns`` (the standard's limit, and the ±100 ns that rate decodes exactly).
Words are built and decoded in batches (numpy waveforms, the compiled decoder), so 2 x 10^7
words take minutes. Prints fresh seeds (rerun one with ``--seed``), then per kind and rate
the words that came out clean and wrong, flagged, clean and right, and lost (nothing
reported), and the CPU and wall time with the load average.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.append(str(Path(__file__).resolve().parents[1]))  # tests.support

from seeds import fresh

from drivers.mil1553.decoder import decode_capture
from tests.support.corruption import KINDS, classify, damaged_words

BATCH = 20_000
"""Words per capture: 0.5 s of line, 52 MB of samples at 100 MS/s."""


def run(kind: str, rate: float, words: int, jitter_ns: float, dead_band_ns: float,
        seed: int) -> tuple[int, int, int, int]:
    """Counts (clean and wrong, flagged, clean and right, lost) over ``words`` words."""
    rng = np.random.default_rng(seed)
    totals = np.zeros(4, dtype=np.int64)
    done = 0
    while done < words:
        count = min(BATCH, words - done)
        batch = damaged_words(kind, count, rate, jitter_ns, rng, dead_band_ns)
        outcome = classify(batch, decode_capture(batch.samples, rate))
        totals += [int(outcome.clean_wrong.sum()), int(outcome.flagged.sum()),
                   int(outcome.clean_right.sum()), int(outcome.lost.sum())]
        done += count
    return int(totals[0]), int(totals[1]), int(totals[2]), int(totals[3])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--words", type=int, default=10_000_000,
                        help="corrupted words in all (split over kinds and rates)")
    parser.add_argument("--clean-words", type=int, default=None,
                        help="clean words at the lowest rate (default: as --words)")
    parser.add_argument("--rates", default="10e6,12.5e6,16e6,20e6,24e6,50e6,100e6,200e6",
                        help="sample rates, Hz, comma-separated; the first is the minimum")
    parser.add_argument("--jitter-ns", type=float, default=150.0,
                        help="every crossing displaced by up to this (the standard's limit)")
    parser.add_argument("--clean-jitter-ns", default="150,100",
                        help="jitters of the clean runs at the minimum rate, comma-separated")
    parser.add_argument("--dead-band-ns", type=float, default=0.0,
                        help="both outputs low this long around each crossing")
    parser.add_argument("--seed", type=int, default=None, help="rerun with this seed")
    args = parser.parse_args()
    rates = sorted(float(r) for r in args.rates.split(","))
    clean_words = args.words if args.clean_words is None else args.clean_words
    seed = fresh(args.seed)
    kinds = [k for k in KINDS if k != "clean"]
    per_cell = max(1, args.words // (len(kinds) * len(rates)))
    print(f"jitter ±{args.jitter_ns:g} ns on every crossing, dead band "
          f"{args.dead_band_ns:g} ns; "
          f"{per_cell} words per kind and rate; {clean_words} clean words at "
          f"{rates[0] / 1e6:g} MS/s per clean jitter; load average {os.getloadavg()[0]:.2f}")
    print(f"{'kind':<14} {'MS/s':>6} {'words':>9} {'clean+wrong':>11} {'flagged':>9} "
          f"{'clean+right':>11} {'lost':>7}")
    start, start_cpu = time.perf_counter(), time.process_time()
    wrong_total = 0
    jobs = [(kind, rate, per_cell, args.jitter_ns) for kind in kinds for rate in rates]
    jobs += [("clean", rates[0], clean_words, float(j))
             for j in args.clean_jitter_ns.split(",") if clean_words]
    for index, (kind, rate, words, jitter) in enumerate(jobs):
        counts = run(kind, rate, words, jitter, args.dead_band_ns, seed + index)
        wrong_total += counts[0]
        label = kind if jitter == args.jitter_ns else f"{kind} ±{jitter:g}"
        print(f"{label:<14} {rate / 1e6:>6g} {words:>9} {counts[0]:>11} {counts[1]:>9} "
              f"{counts[2]:>11} {counts[3]:>7}", flush=True)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    print(f"clean and wrong in all: {wrong_total}; CPU {cpu:.1f} s, wall {wall:.1f} s; "
          f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
