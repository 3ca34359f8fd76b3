"""The decoder's cost in instructions per sample, counted by valgrind's callgrind.

    python bench/decoder_instructions.py [--seconds 0.5] [--seed 4242] [--repeat 2]
                                         [--only clean|worst]

CPU time on a shared machine moves with the other jobs; an instruction count does not, so a
speed change to the decoder is judged by this count first (and by bench/bitpath.py after).
The capture is bench/bitpath.py's dual-redundant loaded bus at 10 MS/s, clean and with the
worst receiver impairments (its default seed is the one the decoder's design is measured
on: quote fresh seeds from bench/bitpath.py for figures). Each capture is decoded under
callgrind in 1 MiB chunks, after a warm-up decode, ``repeat`` times and 0 times: the
difference divided by the decodes and samples is the count per sample, Python between the
kernels included. Needs valgrind on PATH; takes a few minutes.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

CHUNK = 1 << 20


def decode_file(path: str, repeat: int) -> None:
    """(Under valgrind) a warm-up decode, then ``repeat`` more."""
    from drivers.mil1553.decoder import ManchesterDecoder

    samples = np.load(path)
    for _ in range(repeat + 1):
        decoder = ManchesterDecoder(10e6)
        for start in range(0, samples.size, CHUNK):
            decoder.feed(samples[start:start + CHUNK])
        decoder.flush()


def collected(path: str, repeat: int) -> int:
    """Instructions callgrind counted for the whole process."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/out",
             sys.executable, str(Path(__file__).resolve()), "--child", path, str(repeat)],
            capture_output=True, text=True, check=True, env=dict(os.environ))
    match = re.search(r"Collected\s*:\s*(\d+)", run.stderr)
    if match is None:
        raise RuntimeError(f"no callgrind total in:\n{run.stderr[-2000:]}")
    return int(match.group(1))


def main() -> None:
    if len(sys.argv) == 4 and sys.argv[1] == "--child":
        decode_file(sys.argv[2], int(sys.argv[3]))
        return
    from bitpath import dual_redundant

    from drivers.mil1553.encoder import CLEAN, Impairments, encode_words

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=4242)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--only", choices=("clean", "worst"), default=None,
                        help="count one of the two captures")
    args = parser.parse_args()
    print(f"seed {args.seed}, {args.seconds:g} s of bus at 10 MS/s, {args.repeat} decodes")
    # A process under valgrind sees another processor than a native one, so its first run
    # compiles the kernels afresh (and caches them for the next): that run is not counted.
    warm = encode_words(dual_redundant(2e-3, args.seed), 10e6)
    with tempfile.TemporaryDirectory() as tmp:
        np.save(f"{tmp}/warm.npy", warm)
        collected(f"{tmp}/warm.npy", 0)
    worst = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=args.seed + 1)
    for label, imp in (("clean", CLEAN), ("worst", worst)):
        if args.only not in (None, label):
            continue
        samples = encode_words(dual_redundant(args.seconds, args.seed), 10e6, impairments=imp)
        with tempfile.TemporaryDirectory() as tmp:
            path = f"{tmp}/capture.npy"
            np.save(path, samples)
            cost = collected(path, args.repeat) - collected(path, 0)
        print(f"  {label}: {cost / args.repeat / samples.size:.2f} instructions per sample")


if __name__ == "__main__":
    main()
