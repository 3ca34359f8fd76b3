"""From capture samples to line-level segments and zero crossings, one bus at a time.

Two stages, split where the work changes in kind:

* Per sample, the only pass over the samples (one per bus): each sample is compared with the
  next, 64 at a time in vector registers, and the bus's runs are read from the samples where
  its bits change (:func:`bus_runs`).
* Per edge, compiled kernels: short interruptions are repaired, and runs become segments
  with timed crossings (:func:`line_segments`). This is a state machine over a few runs per
  microsecond of traffic; as numpy it took a dozen array passes (each allocating, and paying
  its fixed cost), compiled it is one loop per step.

Terms used here: a *run* is a maximal stretch of samples with one line level (+1 positive,
-1 negative, 0 no signal). A *segment* is a run of +1 or -1. Two segments are *adjacent* when
at most a dead band of silence separates them; a *crossing* is the boundary between two
adjacent segments of opposite polarity, timed at the middle of the dead band. A boundary
to or from a long silence is the start or end of activity.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from drivers.jit import LANES, changed_bits, kernel, population_count, trailing_zeros
from drivers.mil1553.encoder import RX_BITS

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]
Int8Array = npt.NDArray[np.int8]
BoolArray = npt.NDArray[np.bool_]

WRITTEN_FOR_LANES = 64
"""The :data:`~drivers.jit.LANES` this file's kernels step by (64 samples per
:func:`~drivers.jit.changed_bits`, 65 bytes read). numba caches a kernel by its own source
file only, so a change of the lanes in drivers/jit.py alone would leave cached kernels
reading past the samples: such a change must come with one here, which renews this file's
cache."""
if LANES != WRITTEN_FOR_LANES:
    raise ImportError(f"drivers/mil1553/edges.py steps by {WRITTEN_FOR_LANES} samples, "
                      f"drivers/jit.py compares {LANES}: change both (and clear the kernel "
                      "cache)")


class Workspace:
    """Working arrays kept from one buffer to the next, grown when a buffer needs more.

    A buffer's working arrays take 26 MB for a loaded bus at 10 MS/s, most of it never
    written (the runs' arrays are sized for a change at every sample), 56 MB for random
    bytes; allocated afresh each time, they are returned to the system and faulted
    back in page by page for the next buffer, which cost more than the work done on them
    (docs/figures.md). Arrays taken from here are valid until the
    same name is taken again.
    """

    def __init__(self) -> None:
        self._arrays: dict[str, npt.NDArray[Any]] = {}

    def take(self, name: str, size: int, dtype: type[np.generic]) -> npt.NDArray[Any]:
        """An uninitialised array of ``size`` elements (a view of the kept one)."""
        kept = self._arrays.get(name)
        if kept is None or kept.size < size:
            kept = np.empty(max(size, 1024, 0 if kept is None else kept.size * 5 // 4),
                            dtype=dtype)
            self._arrays[name] = kept
        return kept[:size]


_THREAD = threading.local()


def thread_workspace() -> Workspace:
    """The calling thread's workspace: decoders that run one after another in a thread (a
    file after a file) reuse its arrays. One per thread, as a decoder may be fed from any
    thread, and its arrays are in use only during one call."""
    work: Workspace | None = getattr(_THREAD, "work", None)
    if work is None:
        work = _THREAD.work = Workspace()
    return work


def bus_runs(samples: npt.NDArray[np.uint8], bus: int, work: Workspace
             ) -> tuple[IntArray, IntArray]:
    """The runs of ``bus`` in ``samples``: the index where each starts (0 first) and its line
    level (views of ``work``'s arrays, valid until its next use for a bus).

    This is the pass over the samples, one per bus (:func:`_bus_runs`). It compares them 64
    at a time, in vector registers (:data:`drivers.jit.changed_bits`), and visits only the
    samples where the bus's bits change: on a loaded bus at 10 MS/s its line changes every
    5-10 samples, so the work is per change, not per sample, and the other bus's changes are
    never visited.
    """
    pos, neg = RX_BITS[bus]
    starts = work.take("starts", samples.size, np.int64)
    levels = work.take("levels", samples.size, np.int64)
    runs = _bus_runs(samples, pos | neg, _LEVELS[bus], starts, levels)
    return starts[:runs], levels[:runs]


@kernel
def _bus_runs(samples: npt.NDArray[np.uint8], bits: int, line_level: IntArray,
              starts: IntArray, levels: IntArray) -> int:
    """:func:`bus_runs` into ``starts`` and ``levels``; returns the number of runs.

    ``bits`` are the bus's two bits of a capture byte. Each block of 64 samples becomes a
    mask of the samples whose bus bits differ from the sample before; each set bit's sample
    is the block's base plus the count of trailing zeros, and clearing the lowest set bit
    moves to the next: a few instructions per change. The last samples, after the whole
    blocks, are read one at a time. A changed sample starts a run where its level,
    ``line_level[byte]``, differs from the last run's (the bus's two bits can both change
    with the level staying 0: both high is no signal, as both low is); it is written either
    way and kept by moving on, not by a branch.
    """
    n = samples.size
    if n == 0:
        return 0
    previous = line_level[samples[0]]
    starts[0] = 0
    levels[0] = previous
    runs = 1
    one = np.uint64(1)
    blocks = (n - 1) // 64  # block j compares samples 64j to 64j + 64: all in the buffer
    for j in range(blocks):
        word = changed_bits(samples, 64 * j, bits)
        base = 64 * j + 1
        while word:
            at = base + trailing_zeros(word)
            # Unsigned indices: numba then leaves out the wrap-around of negative ones.
            level = line_level[samples[np.uint64(at)]]
            starts[np.uint64(runs)] = at
            levels[np.uint64(runs)] = level
            runs += level != previous
            previous = level
            word &= word - one
    for at in range(64 * blocks + 1, n):
        level = line_level[samples[at]]
        starts[runs] = at
        levels[runs] = level
        runs += level != previous
        previous = level
    return runs


@dataclass(frozen=True, slots=True)
class Segments:
    """The non-silent runs of one bus with their boundary times (in samples, float).

    ``left[k]``/``right[k]`` are crossing times where the neighbour is adjacent and of the
    other polarity, else the time activity starts/stops. ``adjacent_prev[k]`` says segment k
    begins at a crossing (its ``left`` is one).
    """

    level: Int8Array
    left: FloatArray
    right: FloatArray
    adjacent_prev: BoolArray
    crossings: FloatArray
    """Times of all crossings, sorted (the ``left`` of segments that begin at one)."""
    crossing_level: Int8Array
    """The polarity each crossing goes to (+1: negative to positive)."""
    silent_after: FloatArray
    """Times at which activity stops (a segment's ``right`` followed by silence), sorted."""
    candidates: IntArray
    """Sync candidates: segments that begin at a crossing and, like the segment before them,
    are long enough to be half a sync (see :func:`line_segments`)."""
    candidate_crossing: IntArray
    """The index in ``crossings`` of each candidate's crossing."""


def line_segments(samples: npt.NDArray[np.uint8], bus: int, work: Workspace, *,
                  dropout_max: int, glitch_max: int, dead_band_max: int, half_min: float,
                  span_min: float) -> Segments:
    """The segments of ``bus`` in a buffer of samples (C-contiguous); their arrays are views
    of ``work``'s, valid until its next use for a bus.

    The bus's runs are repaired where an interruption is too short to be real:

    * a silent run of at most ``dropout_max`` samples between two segments of the same
      polarity is a drop-out, and a segment of at most ``glitch_max`` samples between two runs
      of the same level is a glitch: both take their neighbours' level. Dead bands (silence
      between opposite polarities) are kept; they are timed as crossings.
    * A half-bit pulse that fell between two samples (silence between two segments of the
      same polarity) is a drop-out too: it is not restored, so the crossings it would have
      made are missing and the bit reader flags the word (a restored pulse would be a guess).

    Each decision looks at the runs as they were found (not as already repaired); runs that
    end up with their neighbour's level are merged into it.

    Segments are then timed. A sample is the line state at its instant; a change happened
    between two samples, so a boundary is timed half a sample before the first sample of the
    new state, and a crossing through a dead band (a silence of at most ``dead_band_max``
    samples between opposite polarities) at the middle of the silence.

    A crossing between two segments of at least ``half_min`` samples each, together at least
    ``span_min``, is a sync candidate: both halves of a sync hold ~1.5 µs and span 3 µs
    between their outer crossings (each off by at most 150 ns), where two long data runs hold
    1 µs each and span 2 µs.
    """
    n = samples.size
    starts, levels = bus_runs(samples, bus, work)
    runs = starts.size
    seg = Segments(work.take("level", runs, np.int8), work.take("left", runs, np.float64),
                   work.take("right", runs, np.float64),
                   work.take("adjacent", _padded(runs), np.bool_),
                   work.take("crossings", runs, np.float64),
                   work.take("crossing_level", runs, np.int8),
                   work.take("silent_after", runs, np.float64),
                   work.take("candidates", runs, np.int64),
                   work.take("candidate_crossing", runs, np.int64))
    live, crossings, ends = _segments(
        starts, levels, runs, n, dropout_max, glitch_max, dead_band_max,
        seg.level, seg.left, seg.right, seg.adjacent_prev, seg.crossings, seg.crossing_level,
        seg.silent_after)
    candidates = sync_candidates(seg, live, half_min, span_min, work)
    return Segments(seg.level[:live], seg.left[:live], seg.right[:live],
                    seg.adjacent_prev[:live], seg.crossings[:crossings],
                    seg.crossing_level[:crossings], seg.silent_after[:ends],
                    seg.candidates[:candidates], seg.candidate_crossing[:candidates])


_LEVELS = {bus: np.array([((value & pos) != 0) - ((value & neg) != 0) for value in range(256)],
                         dtype=np.int64)
           for bus, (pos, neg) in RX_BITS.items()}
"""Per bus, the line level each capture byte shows: RX minus RXB, so both outputs high is no
signal, as both low is."""


@kernel
def _segments(starts: IntArray, levels: IntArray, runs: int, n: int, dropout_max: int,
              glitch_max: int, dead_band_max: int, level: Int8Array,
              left: FloatArray, right: FloatArray, adjacent: BoolArray, crossings: FloatArray,
              crossing_level: Int8Array, silent_after: FloatArray) -> tuple[int, int, int]:
    """The segments of :func:`line_segments` from the bus's ``runs`` runs, written to the
    fields of :class:`Segments` given (each at least ``runs`` long); returns the number of
    segments, crossings and silences.

    One pass over the runs. Each run's repaired level is read from its neighbours as found
    (the first and last runs are never repaired); a run whose repaired level differs from
    the one before it starts a merged run, and the merged run it ends becomes a segment if
    it is not silent. A sentinel after the last run ends the last merged run.

    Most runs of a clean word are a polarity straight after the opposite one, too long to
    be repaired: while the line does that, an inner loop writes each segment and its
    crossing without the general case's tests (it keeps no state the general case does
    not). A dead band between the polarities takes the general case.
    """
    longest = max(dropout_max, glitch_max)
    one = np.uint64(1)
    live = crossing_count = ends = 0
    previous_end = previous_level = 0  # the last segment's
    previous_fixed = 7  # no level: the first run starts a merged run
    merged_begin = merged_level = 0  # the merged run being built (level 0: none emitted)
    r = 0
    while r <= runs:
        if merged_level != 0 and previous_end == merged_begin and live > 0 and \
                previous_level == -merged_level:
            # The merged run follows the last segment at a crossing without silence: while
            # the next run is its opposite and not repairable, it ends as such a segment.
            while r < runs - 1:
                # Unsigned indices: numba then leaves out the wrap-around of negative ones.
                at, new, crossed = np.uint64(r), np.uint64(live), np.uint64(crossing_count)
                begin = starts[at]
                if levels[at] != -merged_level or starts[at + one] - begin <= longest:
                    break
                start = merged_begin - 0.5
                crossings[crossed] = start
                crossing_level[crossed] = merged_level
                crossing_count += 1
                level[new] = merged_level
                left[new] = start
                right[new] = begin - 0.5
                adjacent[new] = True
                live += 1
                merged_begin = begin
                merged_level = -merged_level
                r += 1
            previous_end, previous_level = merged_begin, -merged_level
            previous_fixed = merged_level
        if r < runs:
            at = np.uint64(r)
            found = levels[at]
            begin = starts[at]
            fixed = found
            if 0 < r < runs - 1:
                length = starts[at + one] - begin
                if length <= longest:
                    before = levels[at - one]
                    if before == levels[at + one] and (
                            (found == 0 and before != 0 and length <= dropout_max) or
                            (found != 0 and length <= glitch_max)):
                        fixed = before
        else:
            fixed = 8
            begin = n
        if fixed != previous_fixed:
            if merged_level != 0:
                start = merged_begin - 0.5
                silence = merged_begin - previous_end
                crossing = live > 0 and silence <= dead_band_max and \
                    merged_level != previous_level
                if crossing:
                    if silence != 0:
                        start = (previous_end - 1 + merged_begin) / 2.0
                        right[live - 1] = start
                    crossings[crossing_count] = start
                    crossing_level[crossing_count] = merged_level
                    crossing_count += 1
                elif live > 0:
                    silent_after[ends] = right[live - 1]
                    ends += 1
                level[live] = merged_level
                left[live] = start
                right[live] = begin - 0.5
                adjacent[live] = crossing
                previous_end, previous_level = begin, merged_level
                live += 1
            merged_begin, merged_level = begin, fixed
            previous_fixed = fixed
        r += 1
    if live:
        silent_after[ends] = right[live - 1]
        ends += 1
    return live, crossing_count, ends


def _padded(size: int) -> int:
    """``size`` rounded up to whole 64-bit words of flags (one flag per element)."""
    return -(-size // 64) * 64


def sync_candidates(seg: Segments, live: int, half_min: float, span_min: float,
                    work: Workspace) -> int:
    """The sync candidates among the first ``live`` segments of ``seg`` (see
    :func:`line_segments`), written to its ``candidates`` and ``candidate_crossing``;
    returns their number. ``seg.adjacent_prev`` must be at least :func:`_padded` ``(live)``
    long (flags past ``live`` are never read).

    About one segment in twenty-five is a candidate, so the test is made for all segments at
    once in a loop that compiles to vector instructions (:func:`_candidate_flags`), with no
    running count to carry from one segment to the next; numpy packs the flags (and the
    segments' ``adjacent_prev``) to bits, and a second kernel (:func:`_candidates`) visits
    only the set ones, numbering each candidate's crossing by counting the adjacent flags
    before it.
    """
    size = _padded(live)
    flags = work.take("candidate_flags", size, np.bool_)
    _candidate_flags(seg.left[:live], seg.right[:live], seg.adjacent_prev[:live], half_min,
                     span_min, flags)
    candidate_words = np.packbits(flags, bitorder="little").view(np.uint64)
    adjacent_words = np.packbits(seg.adjacent_prev[:size], bitorder="little").view(np.uint64)
    return _candidates(candidate_words, adjacent_words, seg.candidates,
                       seg.candidate_crossing)


@kernel
def _candidate_flags(left: FloatArray, right: FloatArray, adjacent: BoolArray, half_min: float,
                     span_min: float, flags: BoolArray) -> None:
    """Per segment, whether it is a sync candidate; ``flags`` past the segments are cleared.

    A segment that begins at a crossing is one if it and the segment before it are each at
    least ``half_min`` long, together at least ``span_min``. The first segment never is
    (it has none before it). Bitwise tests and no state from one segment to the next, so the
    loop compiles to vector instructions.
    """
    n = left.size
    if n:
        flags[0] = False
    for j in range(1, n):
        before = right[j - 1] - left[j - 1]
        after = right[j] - left[j]
        flags[j] = adjacent[j] & (before >= half_min) & (after >= half_min) & \
            (before + after >= span_min)
    for j in range(n, flags.size):
        flags[j] = False


@kernel
def _candidates(candidate_words: npt.NDArray[np.uint64], adjacent_words: npt.NDArray[np.uint64],
                candidates: IntArray, candidate_crossing: IntArray) -> int:
    """The candidates flagged in ``candidate_words`` (bit ``j`` of the little-endian words:
    segment ``j``), written with their crossings' indices to ``candidates`` and
    ``candidate_crossing``; returns their number.

    A candidate begins at a crossing, and every segment that begins at one but the first
    segment (which never does) has its crossing next in ``crossings``: a candidate's crossing
    is numbered by the adjacent flags up to it, less one, counted a word at a time.
    """
    found = 0
    before = -1  # adjacent flags in the words before this one, less one
    one = np.uint64(1)
    for w in range(candidate_words.size):
        word = candidate_words[w]
        adjacent = adjacent_words[w]
        while word:
            bit = trailing_zeros(word)
            candidates[found] = 64 * w + bit
            below = (one << np.uint64(bit) << one) - one  # bits 0 to ``bit``
            candidate_crossing[found] = before + population_count(adjacent & below)
            found += 1
            word &= word - one
        before += population_count(adjacent)
    return found
