"""Is the decoder's output unchanged? Compare it, feed by feed, with the decoder of a git revision.

    python bench/decoder_equivalence.py REV [--random 400] [--seconds 0.5] [--seed N]

A speed change to the bit-level decoder must not change a single word. This script builds a
set of captures with the working tree's encoder, then decodes each of them twice, in two
child processes: once with the working tree's ``drivers`` package and once with ``REV``'s
(extracted with ``git archive`` into a cache directory, so its compiled kernels are kept
between runs). Each capture is fed in its own chunking; every feed's words (all fields, byte
for byte) and ``complete_until_ns`` after it must be equal, and so must the flush's.

The captures:

* bench/bitpath.py's dual-redundant loaded bus at 10 MS/s, clean and with the worst receiver
  impairments, each fed in 1 MiB chunks and whole;
* ``--random`` random ones: dual-bus traffic at 10-200 MS/s (contiguous words and gaps) with
  jitter up to ±200 ns, dead bands, bit-rate errors, one-sample glitches, encoder faults
  (parity, missing transitions, bit counts, inverted syncs) and bursts of random bytes; the
  integrity campaign's damaged words (every kind of :mod:`tests.support.corruption`);
  random bytes alone; each fed in a random chunking (a few large chunks, or many small ones).

Prints the seed, the number of captures and feeds compared, and each capture that differs
(exit status 1 if any does).
"""

from __future__ import annotations

import argparse
import hashlib
import itertools
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import numpy.typing as npt

sys.path.insert(0, str(Path(__file__).parent))
sys.path.append(str(Path(__file__).resolve().parents[1]))  # tests.support

ROOT = Path(__file__).resolve().parent.parent
CHUNK = 1 << 20

Case = tuple[str, npt.NDArray[np.uint8], float, npt.NDArray[np.int64]]
"""A capture: its label, samples, sample rate and the chunk boundaries it is fed at."""


def random_cuts(rng: np.random.Generator, n: int) -> npt.NDArray[np.int64]:
    """Chunk boundaries: none, a few anywhere, or many small chunks."""
    style = rng.integers(0, 3)
    if style == 0 or n < 2:
        return np.zeros(0, dtype=np.int64)
    if style == 1:
        return np.unique(rng.integers(1, n, int(rng.integers(1, 12))))
    sizes = rng.integers(1, max(2, n // int(rng.integers(20, 200))), 400)
    cuts = np.cumsum(sizes)
    return cuts[cuts < n].astype(np.int64)


def traffic_case(rng: np.random.Generator) -> tuple[str, npt.NDArray[np.uint8], float]:
    """Random dual-bus traffic with impairments, faults and noise bursts."""
    from drivers.mil1553.encoder import Impairments, WordFault, encode_words
    from drivers.mil1553.wordbatch import empty_words

    rate = float(rng.uniform(10e6, 200e6))
    count = int(rng.integers(5, 60))
    faulty = rng.random() < 0.5
    least = 24_000 if faulty else 20_050
    gaps = rng.choice([least, least, 22_000 + least - 20_050, 31_700, 60_000], count)
    words = empty_words(count)
    words["t_ns"] = int(rng.integers(0, 5000)) + np.cumsum(gaps) - gaps[0]
    words["bus"] = rng.integers(0, 2, count)
    words["sync"] = rng.integers(0, 2, count)
    words["value"] = rng.integers(0, 65536, count)
    choices = [WordFault(parity=True), WordFault(inverted_sync=True),
               *[WordFault(no_transition=int(b)) for b in (0, 1, 7, 15, 16)],
               *[WordFault(bit_count=int(b)) for b in (-17, -9, -2, -1, 1, 3)]]
    faults = [choices[int(rng.integers(len(choices)))] if faulty and rng.random() < 0.4
              else WordFault() for _ in range(count)]
    imp = Impairments(jitter_ns=float(rng.uniform(0, 200)) * (rng.random() < 0.8),
                      dead_band_ns=float(rng.uniform(0, 120)) * (rng.random() < 0.5),
                      rate_error=float(rng.uniform(-1.2e-3, 1.2e-3)),
                      glitch_probability=float(rng.uniform(0, 0.5)) * (rng.random() < 0.3),
                      seed=int(rng.integers(1 << 31)))
    samples = encode_words(words, rate, impairments=imp, faults=faults)
    for _ in range(int(rng.integers(0, 4))):
        length = int(rng.uniform(0.05, 30) * rate / 1e6)
        start = int(rng.integers(0, max(1, samples.size - length)))
        samples[start:start + length] = rng.integers(0, 256, min(length, samples.size - start))
    return f"traffic {count} words", samples, rate


def damaged_case(rng: np.random.Generator) -> tuple[str, npt.NDArray[np.uint8], float]:
    """The integrity campaign's slotted, damaged words."""
    from tests.support.corruption import KINDS, damaged_words

    kind = KINDS[int(rng.integers(len(KINDS)))]
    rate = float(rng.uniform(10e6, 200e6))
    batch = damaged_words(kind, int(rng.integers(5, 40)), rate, float(rng.uniform(0, 150)),
                          rng, dead_band_ns=float(rng.uniform(0, 100)) * (rng.random() < 0.5))
    return f"damaged {kind}", batch.samples, rate


def noise_case(rng: np.random.Generator) -> tuple[str, npt.NDArray[np.uint8], float]:
    """Random bytes, or random bytes on a few of the line states only."""
    rate = float(rng.uniform(10e6, 200e6))
    n = int(rng.integers(1, 60_000))
    samples = rng.integers(0, 256, n).astype(np.uint8)
    if rng.random() < 0.5:  # long runs: one byte held for a random time
        samples = np.repeat(samples[: n // 8 + 1], rng.integers(1, 40, n // 8 + 1))
        samples &= np.uint8(rng.choice([0x03, 0x0C, 0x0F, 0xFF]))
    return "noise", samples, rate


def build_cases(seed: int, random_count: int, seconds: float) -> list[Case]:
    from bitpath import dual_redundant

    from drivers.mil1553.encoder import CLEAN, Impairments, encode_words

    cases: list[Case] = []
    worst = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=seed + 1)
    for label, imp in (("bench clean", CLEAN), ("bench worst", worst)):
        samples = encode_words(dual_redundant(seconds, seed), 10e6, impairments=imp)
        chunked = np.arange(CHUNK, samples.size, CHUNK, dtype=np.int64)
        cases.append((f"{label}, 1 MiB chunks", samples, 10e6, chunked))
        cases.append((f"{label}, whole", samples, 10e6, np.zeros(0, dtype=np.int64)))
    rng = np.random.default_rng(seed)
    makers = (traffic_case, traffic_case, damaged_case, noise_case)
    for _ in range(random_count):
        label, samples, rate = makers[int(rng.integers(len(makers)))](rng)
        cases.append((label, samples, rate, random_cuts(rng, samples.size)))
    return cases


def save_cases(cases: list[Case], path: Path) -> None:
    arrays: dict[str, npt.NDArray[np.generic]] = {}
    for i, (_, samples, rate, cuts) in enumerate(cases):
        arrays[f"samples{i}"] = samples
        arrays[f"cuts{i}"] = cuts
        arrays[f"rate{i}"] = np.array(rate)
    np.savez(path, count=np.array(len(cases)), **arrays)


def decode_cases(cases_path: Path, out_path: Path) -> None:
    """(In the child) decode every capture feed by feed; save each feed's words and horizon."""
    import drivers
    from drivers.mil1553.decoder import ManchesterDecoder

    print(f"  decoding with {Path(drivers.__file__).parent}", flush=True)
    data = np.load(cases_path)
    out: dict[str, npt.NDArray[np.generic]] = {}
    for i in range(int(data["count"])):
        samples, cuts, rate = data[f"samples{i}"], data[f"cuts{i}"], float(data[f"rate{i}"])
        bounds = [0, *cuts.tolist(), samples.size]
        feeds: list[npt.NDArray[np.void]] = []
        horizons: list[float] = []
        decoder = ManchesterDecoder(rate)
        for a, b in itertools.pairwise(bounds):
            feeds.append(decoder.feed(samples[a:b]))
            horizons.append(decoder.complete_until_ns)
        feeds.append(decoder.flush())
        horizons.append(decoder.complete_until_ns)
        out[f"words{i}"] = np.concatenate(feeds)
        out[f"feed{i}"] = np.repeat(np.arange(len(feeds)), [f.size for f in feeds])
        out[f"horizon{i}"] = np.array(horizons)
    np.savez(out_path, **out)


def revision_tree(rev: str) -> Path:
    """``REV``'s ``drivers`` package, extracted once into a cache directory."""
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", f"{rev}^{{commit}}"],
                         check=True, capture_output=True, text=True).stdout.strip()
    where = Path(tempfile.gettempdir()) / f"mapr-decoder-{sha[:16]}"
    if not (where / "drivers").is_dir():
        where.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", sha, "drivers"],
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(where)], input=archive, check=True)
    print(f"revision {rev} = {sha[:12]}")
    return where


def run_child(package_root: Path, cases_path: Path, out_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(package_root))
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--decode",
                    str(cases_path), str(out_path)], check=True, env=env)


def compare(cases: list[Case], ours_path: Path, theirs_path: Path) -> int:
    ours, theirs = np.load(ours_path), np.load(theirs_path)
    differing = feeds = 0
    for i, (label, samples, rate, _) in enumerate(cases):
        feeds += int(ours[f"horizon{i}"].size)
        same = all(ours[f"{key}{i}"].dtype == theirs[f"{key}{i}"].dtype and
                   ours[f"{key}{i}"].tobytes() == theirs[f"{key}{i}"].tobytes()
                   for key in ("words", "feed", "horizon"))
        if not same:
            differing += 1
            print(f"  DIFFERS: case {i} ({label}, {samples.size:,} samples at "
                  f"{rate / 1e6:.2f} MS/s): {ours[f'words{i}'].size} words here, "
                  f"{theirs[f'words{i}'].size} at the revision")
    print(f"{len(cases)} captures, {feeds:,} feeds compared: "
          f"{len(cases) - differing} identical, {differing} differ")
    return differing


def main() -> None:
    if len(sys.argv) == 4 and sys.argv[1] == "--decode":
        decode_cases(Path(sys.argv[2]), Path(sys.argv[3]))
        return
    from seeds import fresh

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", help="git revision whose decoder is the reference")
    parser.add_argument("--random", type=int, default=400, help="random captures")
    parser.add_argument("--seconds", type=float, default=0.5, help="bench captures' bus time")
    parser.add_argument("--seed", type=int, default=None)
    args = parser.parse_args()
    seed = fresh(args.seed)
    reference = revision_tree(args.rev)
    cases = build_cases(seed, args.random, args.seconds)
    digest = hashlib.sha256(b"".join(c[1][:4096].tobytes() for c in cases)).hexdigest()[:12]
    print(f"{len(cases)} captures built ({sum(c[1].size for c in cases):,} samples, "
          f"fingerprint {digest})")
    with tempfile.TemporaryDirectory() as tmp:
        cases_path, ours, theirs = Path(tmp, "cases.npz"), Path(tmp, "a.npz"), Path(tmp, "b.npz")
        save_cases(cases, cases_path)
        run_child(ROOT, cases_path, ours)
        run_child(reference, cases_path, theirs)
        sys.exit(1 if compare(cases, ours, theirs) else 0)


if __name__ == "__main__":
    main()
