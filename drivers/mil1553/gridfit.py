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

The midrange is a compiled kernel: per window, one pass over its crossings builds a 32-bit
mask of occupied bins, and the widest empty arc of the mask is found with a few bit
operations (:func:`_widest_free_arc`), without sorting the phases. Only windows that need the
circular mean count their crossings per bin, in a second pass; their means are one numpy
matrix product for all of them (:func:`circular_mean`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.jit import kernel
from drivers.mil1553.edges import FloatArray, IntArray

PHASE_BINS = 32
"""Resolution of the circular midrange: 1/32 of a half-bit, 15.6 ns."""
CLEAR_GAP = 0.24
"""The midrange is used when the phases leave one widest gap of at least this share of the
circle (0.3 less the bins' quantization); otherwise the circular mean."""

_BIN_ANGLE = 2 * np.pi * (np.arange(PHASE_BINS) + 0.5) / PHASE_BINS
_BIN_COS, _BIN_SIN = np.cos(_BIN_ANGLE), np.sin(_BIN_ANGLE)
_FULL = (1 << PHASE_BINS) - 1


def fit_grids(crossings: FloatArray, lo: IntArray, hi: IntArray, centre: FloatArray,
              half: float) -> FloatArray:
    """Per window ``crossings[lo[i]:hi[i]]``, the offset in half-bits, in [-0.5, 0.5), of the
    grid of ``half`` samples that best fits its crossings' phases relative to ``centre[i]``
    (0 for an empty window): the circular midrange, or the circular mean where the phases
    leave no one clear widest gap (see the module doc).

    The means of all such windows are taken together by numpy (:func:`circular_mean`), from
    their bin counts: a mean near the circle's wrap point must come out the same, to the last
    bit, however the windows are batched, and one matrix product does that.
    """
    fitted, unclear, counts = _fit_midranges(crossings, lo, hi, centre, half)
    if unclear.size:
        fitted[unclear] = circular_mean(counts)
    return fitted


def circular_mean(counts: npt.NDArray[np.int64]) -> FloatArray:
    """Per row of bin counts, the circular mean phase in [-0.5, 0.5) of the circle."""
    sub = counts.astype(np.float64)
    mean = np.arctan2(sub @ _BIN_SIN, sub @ _BIN_COS) / (2 * np.pi)
    result: FloatArray = mean - np.floor(mean + 0.5)
    return result


@kernel
def _fit_midranges(crossings: FloatArray, lo: IntArray, hi: IntArray, centre: FloatArray,
                   half: float) -> tuple[FloatArray, IntArray, npt.NDArray[np.int64]]:
    """The circular midrange of each window of :func:`fit_grids` where one widest gap is
    clear; for the other windows, their indices and their crossings' counts per phase bin."""
    out = np.zeros(centre.size)
    unclear = np.empty(centre.size, dtype=np.int64)
    unclear_count = 0
    scale = PHASE_BINS / half
    for i in range(centre.size):
        if hi[i] <= lo[i]:
            continue
        occupied = 0
        # Unsigned indices: numba then leaves out the wrap-around of negative ones, a few
        # instructions per crossing (``j`` is only ever an index).
        for j in range(np.uint64(lo[i]), np.uint64(hi[i])):
            occupied |= 1 << (int(np.floor((crossings[j] - centre[i]) * scale)) &
                              (PHASE_BINS - 1))
        width, starts = _widest_free_arc(occupied)
        gap = width + 1  # from the occupied bin before the arc to the one after
        if gap < CLEAR_GAP * PHASE_BINS or starts & (starts - 1) != 0:
            unclear[unclear_count] = i
            unclear_count += 1
            continue
        after = 0  # the first free bin of the widest arc
        while not (starts >> after) & 1:
            after += 1
        before = (after + PHASE_BINS - 1) % PHASE_BINS
        middle = (before + 0.5 + (PHASE_BINS + gap) / 2) / PHASE_BINS
        out[i] = middle - np.floor(middle + 0.5)
    counts = np.zeros((unclear_count, PHASE_BINS), dtype=np.int64)
    for row in range(unclear_count):
        i = unclear[row]
        for j in range(lo[i], hi[i]):
            counts[row, int(np.floor((crossings[j] - centre[i]) * scale)) &
                   (PHASE_BINS - 1)] += 1
    return out, unclear[:unclear_count], counts


@kernel
def _rotate_down(mask: int, by: int) -> int:
    """Rotate a 32-bit mask so that bit ``j`` of the result is bit ``j + by`` (mod 32)."""
    rotated: int = ((mask >> by) | (mask << (PHASE_BINS - by))) & _FULL
    return rotated


@kernel
def _widest_free_arc(occupied: int) -> tuple[int, int]:
    """For a 32-bit mask of occupied bins (at least one), the length of the longest circular
    run of free bins, and the mask of the bins where such a longest run starts (one bit per
    run, so more than one bit means a tie).

    ``free_run[m]`` has bit ``j`` set when bins ``j .. j+m-1`` are all free; doubling ``m``
    takes one AND of a rotation. The longest length is then built bit by bit from 16 down,
    keeping the starts of runs that reach it: a binary search in five steps.
    """
    free1 = ~occupied & _FULL
    free2 = free1 & _rotate_down(free1, 1)
    free4 = free2 & _rotate_down(free2, 2)
    free8 = free4 & _rotate_down(free4, 4)
    free16 = free8 & _rotate_down(free8, 8)
    width = 0
    starts = _FULL
    m = 16
    for free in (free16, free8, free4, free2, free1):
        longer = starts & _rotate_down(free, width)
        if longer != 0:
            starts = longer
            width += m
        m >>= 1
    return width, starts
