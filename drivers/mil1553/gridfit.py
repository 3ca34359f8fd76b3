"""Fitting a word's 0.5 µs half-bit grid to its crossings: the circular midrange.

Every crossing of a word lies near a multiple of the half-bit from the sync's start, each
displaced by its own jitter. Their phases on the half-bit (a circle) are binned into
:data:`PHASE_BINS`; the grid's offset is the middle of the shortest arc of the circle that
holds every occupied bin (the circular midrange). With n crossings each displaced by a bounded
jitter, its error shrinks like 1/n where a mean's shrinks like 1/sqrt(n), and it bounds every
crossing's distance to its grid slot by half the spread of the phases, which is what slot
assignment needs. Where the phases spread round most of the circle (a low sample rate
quantizes them into a few values, all occupied) the widest gap says nothing, and the
circular mean (the densest region) is used instead.

Nothing here loops over words or sorts phases: each word's occupied bins become one 32-bit
mask (one ``bitwise_or.reduceat`` over all crossings of a buffer), and the widest empty arc
of every mask is found by a bit-parallel binary search (:func:`widest_free_arc`), a few
operations on all masks at once. Only the words that need the circular mean build their
per-bin counts.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.mil1553.edges import FloatArray, IntArray

PHASE_BINS = 32
"""Resolution of the circular midrange: 1/32 of a half-bit, 15.6 ns."""
CLEAR_GAP = 0.24
"""The midrange is used when the phases leave one widest gap of at least this share of the
circle (0.3 less the bins' quantization); otherwise the circular mean."""

_BIN_ANGLE = 2 * np.pi * (np.arange(PHASE_BINS) + 0.5) / PHASE_BINS
_BIN_COS, _BIN_SIN = np.cos(_BIN_ANGLE), np.sin(_BIN_ANGLE)


def range_indices(lo: IntArray, hi: IntArray) -> tuple[IntArray, IntArray]:
    """The indices of the concatenated ranges ``[lo[i], hi[i])``, and each range's length
    (0 where ``hi <= lo``). No Python loop: one ``repeat`` and one ``arange``."""
    count = np.maximum(hi - lo, 0)
    filled = np.flatnonzero(count)
    # Steps of +1, except at the start of each range, which jumps from the previous one's
    # end; a running sum (in place, one array) turns them into the indices.
    index: IntArray = np.ones(int(count.sum()), dtype=np.int64)
    if index.size:
        first = (np.cumsum(count) - count)[filled]
        starts = lo[filled]
        index[first[0]] = starts[0]
        index[first[1:]] = starts[1:] - (starts[:-1] + count[filled][:-1] - 1)
        np.cumsum(index, out=index)
    return index, count


def grid_phases(crossings: FloatArray, lo: IntArray, hi: IntArray, centre: FloatArray,
                half: float) -> tuple[npt.NDArray[np.int32], IntArray]:
    """The phase bin (0 to PHASE_BINS - 1) of each crossing of ``crossings[lo[i]:hi[i]]``
    relative to ``centre[i]`` on a grid of ``half`` samples, concatenated, and each window's
    crossing count."""
    index, count = range_indices(lo, hi)
    scale = PHASE_BINS / half
    phase = crossings[index]
    del index
    phase -= np.repeat(centre, count)
    phase *= scale
    bins = np.floor(phase, out=phase).astype(np.int32)
    bins &= PHASE_BINS - 1
    return bins, count


def fit_grid(bins: npt.NDArray[np.int32], count: IntArray) -> FloatArray:
    """Per window of ``count`` consecutive phase bins, the grid offset in half-bits,
    in [-0.5, 0.5) (0 for an empty window).

    Each window's occupied bins become one 32-bit mask (a single ``bitwise_or.reduceat``
    over every crossing of the buffer); the widest empty arc of every mask is then found
    with a few bit operations on all masks at once (:func:`widest_free_arc`), so no per-word
    sort or per-bin table is built. Only windows without one clear widest gap (see the
    module doc) need their bin counts, for the circular mean.
    """
    out = np.zeros(count.size)
    filled = np.flatnonzero(count)
    if filled.size == 0:
        return out
    first = (np.cumsum(count) - count)[filled]
    marks = np.left_shift(np.uint64(1), bins.astype(np.uint64))
    occupied = np.bitwise_or.reduceat(marks, first)
    width, starts = widest_free_arc(occupied)
    gap = width.astype(np.int64) + 1  # from the occupied bin before the arc to the one after
    # The occupied bin before the widest arc (its lowest start when there are several).
    lowest = starts & (~starts + np.uint64(1))
    after = np.frexp(lowest.astype(np.float64))[1] - 1
    before = (after - 1) % PHASE_BINS
    middle = (before + 0.5 + (PHASE_BINS + gap) / 2) / PHASE_BINS
    out[filled] = middle - np.floor(middle + 0.5)
    unclear = (gap < CLEAR_GAP * PHASE_BINS) | (np.bitwise_count(starts) > 1)
    if unclear.any():
        groups = filled[unclear]
        member = np.zeros(count.size, dtype=bool)
        member[groups] = True
        local = np.repeat(np.arange(groups.size), count[groups])
        tally = np.bincount(local * PHASE_BINS + bins[np.repeat(member, count)],
                            minlength=groups.size * PHASE_BINS)
        out[groups] = circular_mean(tally.reshape(groups.size, PHASE_BINS))
    return out


_FULL = np.uint64((1 << PHASE_BINS) - 1)


def _rotate_down(masks: npt.NDArray[np.uint64], by: npt.NDArray[np.uint64] | np.uint64
                 ) -> npt.NDArray[np.uint64]:
    """Rotate 32-bit masks so that bit ``j`` of the result is bit ``j + by`` (mod 32)."""
    rotated: npt.NDArray[np.uint64] = (masks >> by) | ((masks << (np.uint64(PHASE_BINS) - by))
                                                      & _FULL)
    return rotated


def widest_free_arc(occupied: npt.NDArray[np.uint64]
                    ) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint64]]:
    """Per 32-bit mask of occupied bins (at least one), the length of the longest circular
    run of free bins, and the mask of the bins where such a longest run starts (one bit per
    run, so more than one bit means a tie).

    ``free_run[m]`` has bit ``j`` set when bins ``j .. j+m-1`` are all free; doubling ``m``
    takes one AND of a rotation. The longest length is then built bit by bit from 16 down,
    keeping the starts of runs that reach it: a binary search run on every mask at once.
    """
    free_run = {1: ~occupied & _FULL}
    for m in (1, 2, 4, 8):
        free_run[2 * m] = free_run[m] & _rotate_down(free_run[m], np.uint64(m))
    width = np.zeros(occupied.size, dtype=np.uint64)
    starts = np.full(occupied.size, _FULL, dtype=np.uint64)
    for m in (16, 8, 4, 2, 1):
        longer = starts & _rotate_down(free_run[m], width)
        reach = longer != 0
        starts = np.where(reach, longer, starts)
        width += reach.astype(np.uint64) * np.uint64(m)
    return width, starts


def circular_mean(counts: npt.NDArray[np.int64]) -> FloatArray:
    """Per row of bin counts, the circular mean phase in [-0.5, 0.5) of the circle."""
    sub = counts.astype(np.float64)
    mean = np.arctan2(sub @ _BIN_SIN, sub @ _BIN_COS) / (2 * np.pi)
    result: FloatArray = mean - np.floor(mean + 0.5)
    return result
