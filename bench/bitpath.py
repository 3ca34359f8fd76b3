"""The bit-level path: samples -> words (decoder) and samples -> messages (decoder + assembler).

    python bench/bitpath.py [--seconds 1] [--rate 10e6] [--seed N]

Traffic: a fully loaded bus of real messages (bench/assembler.py's mix: 32-word BC-RT,
16-word RT-BC, RT-RT, mode codes with data, broadcasts, a no-response), its data words
drawn from the printed seed, the messages alternating between bus A and bus B (one bus
active at a time, as on a dual-redundant bus), encoded at 10 MS/s, clean and with the
standard's worst receiver impairments. Fed in 1 MiB chunks as ``mapr decode`` reads a file,
on one core, no JSON:

* decoder alone (:class:`~drivers.mil1553.decoder.ManchesterDecoder`);
* decoder + assembler (:class:`~drivers.pipeline.SamplePipeline`, MonitorRecords out).

Each figure is the best of three; real-time factors by CPU time of this thread (wall time
beside it: the machine is shared) and the load average, all from this one run.
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

from assembler import loaded_bus
from seeds import fresh

from drivers.mil1553.decoder import ManchesterDecoder
from drivers.mil1553.encoder import CLEAN, Impairments, encode_words
from drivers.pipeline import SamplePipeline

CHUNK = 1 << 20


def best_of(job: Callable[[], int], repeats: int = 3) -> tuple[float, float, int]:
    """(best CPU s of this thread, best wall s, items)."""
    cpu = wall = float("inf")
    items = 0
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.thread_time()
        items = job()
        cpu = min(cpu, time.thread_time() - start_cpu)
        wall = min(wall, time.perf_counter() - start)
    return cpu, wall, items


def decoder_only(samples: np.ndarray, rate: float) -> int:
    decoder = ManchesterDecoder(rate)
    count = 0
    for start in range(0, samples.size, CHUNK):
        count += decoder.feed(samples[start:start + CHUNK]).size
    return count + decoder.flush().size


def decoder_and_assembler(samples: np.ndarray, rate: float) -> int:
    pipeline = SamplePipeline(rate)
    count = 0
    for start in range(0, samples.size, CHUNK):
        count += len(pipeline.feed(samples[start:start + CHUNK]))
    return count + len(pipeline.flush())


def dual_redundant(seconds: float, seed: int) -> np.ndarray:
    """bench/assembler.py's loaded bus, each message on bus A or B in turn (words spread
    by 0.2 % so the worst impairments' slow clock keeps them apart)."""
    words = loaded_bus(seconds, seed)
    words["t_ns"] = words["t_ns"] * 1002 // 1000   # room for a 0.1 % slow transmitter clock
    gaps = np.diff(words["t_ns"], prepend=-10**9) > 20_040 + 3_000
    starts = gaps & (words["sync"] == 1)
    message = np.cumsum(starts)
    words["bus"] = (message % 2).astype(np.uint8)
    return words


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="bus time")
    parser.add_argument("--rate", type=float, default=10e6, help="sample rate, Hz")
    parser.add_argument("--seed", type=int, default=None)
    args = parser.parse_args()
    seed = fresh(args.seed)
    rate = args.rate
    worst = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=seed + 1)
    decoder_and_assembler(encode_words(dual_redundant(2e-3, seed), rate), rate)  # kernels
    print(f"{args.seconds:g} s of bus time at {rate / 1e6:g} MS/s; load average "
          f"{os.getloadavg()[0]:.2f}")
    for label, impairments in (("clean", CLEAN), ("worst impairments", worst)):
        words = dual_redundant(args.seconds, seed)
        samples = encode_words(words, rate, impairments=impairments)
        bus_s = samples.size / rate
        d_cpu, d_wall, n_words = best_of(lambda s=samples: decoder_only(s, rate))
        p_cpu, p_wall, n_messages = best_of(lambda s=samples: decoder_and_assembler(s, rate))
        print(f"\n{label}: {words.size:,} words sent, {n_words:,} decoded, "
              f"{n_messages:,} messages")
        print(f"  decoder alone        {bus_s / d_cpu:6.1f}x real time by CPU "
              f"({bus_s / d_wall:5.1f}x wall)")
        print(f"  decoder + assembler  {bus_s / p_cpu:6.1f}x real time by CPU "
              f"({bus_s / p_wall:5.1f}x wall)")
        print(f"  assembler share of the CPU time: {(p_cpu - d_cpu) / p_cpu:.0%}; "
              f"assembler alone {n_words / max(p_cpu - d_cpu, 1e-9) / 1e6:.2f} M words/s")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
