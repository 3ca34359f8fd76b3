"""Decoder throughput: samples/s and real-time factor on a 100 %-loaded dual-redundant bus.

    python bench/codec.py [--seconds 0.5] [--rate 10e6]

Builds a capture at 10 MS/s in which the bus is never idle: messages of 32 back-to-back words
alternate between bus A and bus B (one bus active at a time, as on a dual-redundant bus), with
the standard's worst receiver impairments. Measures, in one run on one core:

* the streaming decoder (a numpy pass over the samples, compiled kernels over the edges) fed
  1 MiB chunks (as ``mapr decode`` reads a file);
* the same on a stress capture with both buses fully loaded at once (twice the words);
* a naive per-sample Python decoder (bench/naive_decoder.py) on a slice of the clean capture.

Each figure is the best of three timings; the ratio is between figures of this same run. The
real-time factor is wall-clock time; the CPU time the decoding thread used is printed next to
it, with the load average, because on a shared machine other processes stretch the wall clock.

The decoder's per-edge stages are compiled kernels (drivers/jit.py): the first call in a
process compiles them (a fresh install) or loads them from the on-disk cache. That first call
is timed on its own and printed once; it is not part of the figures.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from naive_decoder import decode_naive

from drivers.mil1553.decoder import ManchesterDecoder
from drivers.mil1553.encoder import CLEAN, Impairments, encode_words
from drivers.mil1553.wordbatch import empty_words

CHUNK = 1 << 20


def loaded_bus(seconds: float, both_buses: bool, seed: int = 1) -> np.ndarray:
    """Words filling the bus: 32-word messages back to back, alternating A and B."""
    word_ns = 20_030  # 20 µs plus room for a 0.1 % slow clock
    per_bus = int(seconds * 1e9 / word_ns)
    rng = np.random.default_rng(seed)
    t = np.arange(per_bus, dtype=np.int64) * word_ns
    words = empty_words(per_bus * (2 if both_buses else 1))
    words["t_ns"][:per_bus] = t
    if both_buses:  # bus A and bus B each carry words back to back
        words["t_ns"][per_bus:] = t + 7_000
        words["bus"][per_bus:] = 1
    else:
        words["bus"] = (np.arange(per_bus) // 32) % 2
    words["sync"] = (np.arange(words.size) % 32 == 0).astype(np.uint8)
    words["value"] = rng.integers(0, 65536, words.size)
    return words


def best_of(repeats: int, job: Callable[[], object]) -> tuple[float, float]:
    """Best wall-clock and best thread CPU time of ``repeats`` runs, in seconds."""
    wall = cpu = float("inf")
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.thread_time()
        job()
        cpu = min(cpu, time.thread_time() - start_cpu)
        wall = min(wall, time.perf_counter() - start)
    return wall, cpu


def decode_stream(samples: np.ndarray, rate: float) -> int:
    decoder = ManchesterDecoder(rate)
    count = 0
    for start in range(0, samples.size, CHUNK):
        count += decoder.feed(samples[start:start + CHUNK]).size
    return count + decoder.flush().size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=0.5, help="bus time to decode")
    parser.add_argument("--rate", type=float, default=10e6, help="sample rate, Hz")
    parser.add_argument("--naive-ms", type=float, default=20.0,
                        help="bus time given to the naive decoder, ms")
    args = parser.parse_args()
    rate, seconds = args.rate, args.seconds
    worst = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=3)

    start = time.perf_counter()
    ManchesterDecoder(rate).decode_all(encode_words(loaded_bus(1e-3, False), rate))
    print(f"first decode in this process (compiles the kernels, or loads them from the cache): "
          f"{time.perf_counter() - start:.2f} s")
    print(f"capture: {seconds:g} s of bus time at {rate / 1e6:g} MS/s; "
          f"load average {os.getloadavg()[0]:.2f}")
    rows = []
    for label, both, imp in (("dual-redundant, 100 % loaded, worst impairments", False, worst),
                             ("dual-redundant, 100 % loaded, clean", False, CLEAN),
                             ("stress: A and B both 100 % loaded at once", True, worst)):
        words = loaded_bus(seconds, both)
        samples = encode_words(words, rate, impairments=imp)
        decoded = decode_stream(samples, rate)
        wall, cpu = best_of(3, lambda s=samples: decode_stream(s, rate))
        rows.append((label, samples.size, words.size, decoded, wall, cpu))

    words = loaded_bus(args.naive_ms / 1e3, False)
    samples = encode_words(words, rate)
    naive_words = decode_naive(samples, rate)
    fast = ManchesterDecoder(rate).decode_all(samples)
    agree = [(int(w["bus"]), int(w["sync"]), int(w["value"])) for w in fast] == \
        [(b, s, v) for _, b, s, v in naive_words]
    naive_wall, naive_cpu = best_of(1, lambda: decode_naive(samples, rate))
    rows.append(("naive per-sample decoder, clean", samples.size, words.size,
                 len(naive_words), naive_wall, naive_cpu))

    print(f"{'decoder / capture':<50} {'words':>7} {'decoded':>7} {'Msamples/s':>10} "
          f"{'x real time':>11} {'(by CPU time)':>13}")
    for label, n_samples, n_words, n_decoded, wall, cpu in rows:
        sps = n_samples / wall
        print(f"{label:<50} {n_words:>7} {n_decoded:>7} {sps / 1e6:>10.1f} "
              f"{sps / rate:>11.1f} {n_samples / cpu / rate:>13.1f}")
    vec = rows[1][1] / rows[1][4]
    naive = rows[-1][1] / rows[-1][4]
    print(f"decoder vs naive on the same clean traffic: {vec / naive:.0f}x faster "
          f"(naive agrees with the decoder: {agree}); load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
