"""The bit scans of the edge stage, against plain definitions.

:func:`drivers.mil1553.edges.bus_runs` finds where a bus's line level changes from packed
flags with a count-trailing-zeros intrinsic (:data:`drivers.jit.trailing_zeros`), and
:func:`drivers.mil1553.edges.sync_candidates` (through ``line_segments``) numbers its
candidates' crossings with a population count (:data:`drivers.jit.population_count`); all
are checked here against what they stand for, at the edges that bit tricks get wrong: bits
0 and 63, zero, lengths around 64, changes at the last sample, and both of a bus's bits
changing at once with its level staying "no signal".
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.jit import changed_bits, kernel, population_count, trailing_zeros
from drivers.mil1553.edges import (
    Workspace,
    bus_runs,
    line_segments,
)
from drivers.mil1553.encoder import RX_BITS


@kernel
def _trailing_zeros_of(words: npt.NDArray[np.uint64], out: npt.NDArray[np.int64]) -> None:
    """:data:`trailing_zeros` of each word (it is callable from kernels only)."""
    for i in range(words.size):
        out[i] = trailing_zeros(words[i])


@kernel
def _population_count_of(words: npt.NDArray[np.uint64], out: npt.NDArray[np.int64]) -> None:
    """:data:`population_count` of each word (callable from kernels only)."""
    for i in range(words.size):
        out[i] = population_count(words[i])


@kernel
def _changed_bits_at(samples: npt.NDArray[np.uint8], starts: npt.NDArray[np.int64], bits: int,
                     out: npt.NDArray[np.uint64]) -> None:
    """:data:`changed_bits` at each start (callable from kernels only)."""
    for i in range(starts.size):
        out[i] = changed_bits(samples, starts[i], bits)


def trailing_zeros_by_definition(word: int) -> int:
    """Zero bits below the lowest set bit of a 64-bit word; 64 for zero."""
    if word == 0:
        return 64
    count = 0
    while not word >> count & 1:
        count += 1
    return count


def test_bit_intrinsics_match_definitions() -> None:
    rng = np.random.default_rng(18)
    edges = [0, 1, 2, 3, 1 << 62, 1 << 63, (1 << 63) | 1, (1 << 64) - 1, (1 << 64) - 2]
    singles = [1 << k for k in range(64)]
    # Random words with their low bits cleared, so every count from 0 to 63 is common.
    shifts = rng.integers(0, 64, 2000).astype(np.uint64)
    randoms = (rng.integers(0, 1 << 63, 2000, dtype=np.uint64) << np.uint64(1)
               | np.uint64(1)) << shifts
    words = np.concatenate([np.array(edges + singles, dtype=np.uint64), randoms])
    out = np.empty(words.size, dtype=np.int64)
    _trailing_zeros_of(words, out)
    assert out.tolist() == [trailing_zeros_by_definition(int(w)) for w in words]
    _population_count_of(words, out)
    assert out.tolist() == [bin(int(w)).count("1") for w in words]


def test_changed_bits_matches_definition() -> None:
    """Every start of a buffer (unaligned loads), every mask of one or two bits and all
    eight, on samples with long runs, single-sample changes and changes in other bits."""
    rng = np.random.default_rng(65)
    samples = np.repeat(rng.integers(0, 256, 100), rng.integers(1, 12, 100)).astype(np.uint8)
    samples[::17] ^= np.uint8(0x80)
    starts = np.arange(samples.size - 64, dtype=np.int64)
    out = np.empty(starts.size, dtype=np.uint64)
    for bits in [1 << k for k in range(8)] + [0x03, 0x0C, 0x81, 0xFF]:
        _changed_bits_at(samples, starts, bits, out)
        differ = (samples[1:] ^ samples[:-1]) & bits != 0
        expected = [sum(int(differ[s + k]) << k for k in range(64)) for s in starts.tolist()]
        assert out.tolist() == expected


def level_of(byte: int, bus: int) -> int:
    """The line level a capture byte shows on ``bus``: RX minus RXB."""
    pos, neg = RX_BITS[bus]
    return int(byte & pos != 0) - int(byte & neg != 0)


def runs_by_definition(samples: npt.NDArray[np.uint8], bus: int) -> tuple[list[int], list[int]]:
    """Where each run of one level starts, and its level, sample by sample."""
    starts: list[int] = []
    levels: list[int] = []
    for i, byte in enumerate(samples.tolist()):
        level = level_of(byte, bus)
        if not levels or level != levels[-1]:
            starts.append(i)
            levels.append(level)
    return starts, levels


def check(samples: npt.NDArray[np.uint8], work: Workspace) -> None:
    for bus in RX_BITS:
        starts, levels = bus_runs(samples, bus, work)
        assert (starts.tolist(), levels.tolist()) == runs_by_definition(samples, bus)


def test_bus_runs_every_length_and_pattern() -> None:
    """Lengths 0-200 (partial and whole 64-sample words, partial bytes of flags), with no
    change, every sample changing, and random changes; one workspace throughout, as in the
    decoder, so arrays kept from a longer buffer are reused by a shorter one."""
    rng = np.random.default_rng(40)
    work = Workspace()
    for n in range(201):
        check(np.zeros(n, dtype=np.uint8), work)
        check(np.resize(np.array([0x00, 0x05, 0x0A, 0x0F, 0x03, 0x0C], dtype=np.uint8), n),
              work)
        check(rng.integers(0, 16, n).astype(np.uint8), work)
        check(np.repeat(rng.integers(0, 256, n), rng.integers(1, 9, n))[:n].astype(np.uint8),
              work)


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=3000), st.integers(0, 7))
def test_bus_runs_random_bytes(data: bytes, offset: int) -> None:
    """Any bytes, and a view that starts inside a 64-bit word of its base array."""
    base = np.frombuffer(bytes(offset) + data, dtype=np.uint8)
    check(base[offset:], Workspace())


def candidates_by_definition(left: list[float], right: list[float], adjacent: list[bool],
                             half_min: float, span_min: float) -> tuple[list[int], list[int]]:
    """Segment by segment: a segment that begins at a crossing, long enough and after one
    long enough; its crossing is the how-manieth segment beginning at one it is, from 0."""
    found: list[int] = []
    crossing: list[int] = []
    count = -1
    for j in range(1, len(left)):
        count += adjacent[j]
        before, after = right[j - 1] - left[j - 1], right[j] - left[j]
        if adjacent[j] and before >= half_min and after >= half_min and \
                before + after >= span_min:
            found.append(j)
            crossing.append(count)
    return found, crossing


def test_sync_candidates_match_definition() -> None:
    """Segments of random lines (runs of 1-40 samples, silences, both buses' bits), and
    their candidates counted anew from the segments' lengths; thresholds that make most
    segments candidates exercise many set bits per 64-bit word. One workspace throughout, so
    the flags past the segments hold a longer buffer's (they must not count)."""
    rng = np.random.default_rng(7)
    work = Workspace()
    for trial in range(300):
        n = int(rng.integers(0, 3000))
        samples = np.repeat(rng.integers(0, 16, n), rng.integers(1, 41, n))[:n].astype(np.uint8)
        half_min, span_min = [(9.5, 25.0), (1.0, 2.0), (0.0, 0.0)][trial % 3]
        for bus in RX_BITS:
            seg = line_segments(samples, bus, work, dropout_max=3, glitch_max=trial % 2,
                                dead_band_max=3, half_min=half_min, span_min=span_min)
            expected = candidates_by_definition(seg.left.tolist(), seg.right.tolist(),
                                                seg.adjacent_prev.tolist(), half_min, span_min)
            assert (seg.candidates.tolist(), seg.candidate_crossing.tolist()) == expected
            assert all(seg.crossings[c] == seg.left[k]
                       for k, c in zip(seg.candidates, seg.candidate_crossing, strict=True))
