"""The decoder's cost in instructions per sample, counted by valgrind's callgrind.

    python bench/decoder_instructions.py [--seconds 0.5] [--seed 4242] [--repeat 2]
                                         [--only clean|worst]

CPU time on a shared machine moves with the other jobs; an instruction count does not, so a
speed change to the decoder is judged by this count first (and by bench/bitpath.py after).
The capture is bench/bitpath.py's dual-redundant loaded bus at 10 MS/s, clean and with the
worst receiver impairments (its default seed is the one the decoder's design is measured
on: quote fresh seeds from bench/bitpath.py for figures). Each capture is decoded under
callgrind in 1 MiB chunks, once to warm up (a process under valgrind sees another processor,
so its first run compiles the kernels afresh), then ``repeat`` times with only those decodes
counted: the count per sample includes the Python between the kernels, and nothing of the
interpreter's start. The child's string hashing is fixed (``PYTHONHASHSEED=0``): with it
drawn afresh, the count moved by up to 0.5 per sample between runs of the same code. Needs
valgrind on PATH; takes a minute or two.
"""

from __future__ import annotations

import argparse
import functools
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
    """(Under valgrind) a warm-up decode, then ``repeat`` more inside ``functools.reduce``,
    the C function whose instructions callgrind is told to count (and only those)."""
    from drivers.mil1553.decoder import ManchesterDecoder

    samples = np.load(path)

    def decode(count: int, _: int) -> int:
        decoder = ManchesterDecoder(10e6)
        for start in range(0, samples.size, CHUNK):
            count += decoder.feed(samples[start:start + CHUNK]).size
        return count + decoder.flush().size

    decode(0, 0)
    functools.reduce(decode, range(repeat), 0)


def collected(path: str, repeat: int) -> int:
    """Instructions callgrind counted inside ``functools.reduce`` (the decodes)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/out",
             "--collect-atstart=no", "--toggle-collect=functools_reduce",
             sys.executable, str(Path(__file__).resolve()), "--child", path, str(repeat)],
            capture_output=True, text=True, check=True, env=dict(os.environ, PYTHONHASHSEED="0"))
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
    # The first process after the kernels' source changes compiles them, and its count comes
    # out about 1 per sample higher than the next ones' (which load them from the cache):
    # one short run goes first, not counted.
    with tempfile.TemporaryDirectory() as tmp:
        np.save(f"{tmp}/warm.npy", encode_words(dual_redundant(2e-3, args.seed), 10e6))
        collected(f"{tmp}/warm.npy", 1)
    worst = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=args.seed + 1)
    for label, imp in (("clean", CLEAN), ("worst", worst)):
        if args.only not in (None, label):
            continue
        samples = encode_words(dual_redundant(args.seconds, args.seed), 10e6, impairments=imp)
        with tempfile.TemporaryDirectory() as tmp:
            path = f"{tmp}/capture.npy"
            np.save(path, samples)
            cost = collected(path, args.repeat)
        print(f"  {label}: {cost / args.repeat / samples.size:.2f} instructions per sample")


if __name__ == "__main__":
    main()
