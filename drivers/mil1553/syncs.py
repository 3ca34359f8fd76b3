"""Finding the syncs of one bus: where words start, each anchored on its own fitted grid.

1. *Candidates.* A crossing with at least ~1 µs of one polarity before it and of the other
   after it is a sync candidate (data bits never hold a level for more than 1 µs), if both
   sides together span enough to tell it from two long data runs. They are marked while the
   segments are built (:func:`drivers.mil1553.edges.line_segments`).
2. *Anchor.* Each candidate's 0.5 µs grid is fitted to the crossings from its middle crossing
   to slot 36.5, or to where the line falls silent (:mod:`drivers.mil1553.gridfit`); the
   anchor is the grid's slot 0, the sync's start.
3. *Validation.* A real sync holds its level for three half-bits on each side: the segment
   before the middle crossing must start at or before grid slot 0 and the one after it end at
   or after slot 6; anything else (a long data run) is not a sync. A candidate inside the
   previous word that is not followed by the mid-bit crossings of bits 0 and 1 is the end of
   that word, and a candidate overlapping the previous sync is data.

Steps 2 and 3 are compiled kernels over the candidates, with the grid-fit kernel; so are the
words' extents and the segments no word explains (the decoder's noise bursts), which walk the
same sorted arrays with :func:`walk_to`. Python only passes the arrays between them (a
kernel calls no kernel of another module, so that the on-disk cache of each stays valid when
the other module changes).
"""

from __future__ import annotations

import numpy as np

from drivers.jit import kernel
from drivers.mil1553.edges import BoolArray, FloatArray, Int8Array, IntArray, Segments
from drivers.mil1553.gridfit import fit_grids


def find_syncs(seg: Segments, half: float) -> tuple[FloatArray, Int8Array]:
    """Anchors (sync start, in samples) of the valid syncs among the segments' candidates,
    in order, and each sync's first polarity. ``half`` is the half-bit in samples."""
    k = seg.candidates
    middle, lo, hi = _windows(k, seg.candidate_crossing, seg.left, seg.crossings,
                              seg.silent_after, half)
    correction = fit_grids(seg.crossings, lo, hi, middle, half)
    return _validate(k, middle, correction, seg.level, seg.left, seg.right, seg.adjacent_prev,
                     seg.crossings, half)


@kernel
def _windows(k: IntArray, crossing: IntArray, left: FloatArray, crossings: FloatArray,
             silent_after: FloatArray, half: float) -> tuple[FloatArray, IntArray, IntArray]:
    """Per candidate (the segment ``k`` after its middle crossing, that crossing's index),
    the crossing's time and the window of crossings its grid is fitted to: from a quarter bit
    before it up to slot 36.5, before a contiguous next word's sync (slot 40) would start, or
    up to where the line falls silent, so a later word's crossings never pull the grid.
    """
    middle = np.empty(k.size)
    lo = np.empty(k.size, dtype=np.int64)
    hi = np.empty(k.size, dtype=np.int64)
    # Each bound is found by walking from a known index (as np.searchsorted(...,
    # side="left") would find it): the window's start back from the candidate's crossing,
    # its end and the next silence on from the last candidate's (both only move forward).
    last = silent = 0
    for i in range(k.size):
        at = left[np.uint64(k[i])]  # unsigned indices: no wrap-around of negative ones
        middle[i] = at
        first = crossing[i]
        while first > 0 and crossings[np.uint64(first - 1)] >= at - 0.5 * half:
            first -= 1
        silent = walk_to(silent_after, at, silent)
        stop = silent_after[silent] if silent < silent_after.size else np.inf
        end = min(at + 36.5 * half, stop)
        last = walk_to(crossings, end, max(last, first))
        lo[i], hi[i] = first, last
    return middle, lo, hi


@kernel
def _validate(k: IntArray, middle: FloatArray, correction: FloatArray, level: Int8Array,
              left: FloatArray, right: FloatArray, adjacent_prev: BoolArray,
              crossings: FloatArray, half: float) -> tuple[FloatArray, Int8Array]:
    """The anchors and first polarities of the candidates that are syncs (module doc, step 3).

    The first half may follow idle (any length before it is silence), or follow the previous
    word's last half-bit (slot -1); a longer level before a crossing is data with a missing
    transition, not a sync. At the tolerance limits the end of a word can look like a sync (a
    long data run, then the parity bit or the next sync's first half); such a candidate lies
    inside the previous word's 20 µs and lacks the mid-bit crossings of bits 0 and 1, which
    every real word has (a word with a missing transition there does not start inside another
    word, so it is kept). Each test looks at the candidates the previous one kept.
    """
    spus = 2 * half
    anchors = np.empty(k.size)
    first = np.empty(k.size, dtype=np.int8)
    valid = 0
    for i in range(k.size):
        anchor = middle[i] - 3 * half + correction[i] * half
        # Unsigned indices: numba then leaves out the wrap-around of negative ones.
        after = np.uint64(k[i])  # the candidate segment, after the middle crossing
        before = left[after - np.uint64(1)]
        first_ok = not adjacent_prev[after - np.uint64(1)] or before >= anchor - 1.6 * half
        if first_ok and before <= anchor + 0.5 * half and right[after] >= anchor + 5.5 * half:
            anchors[valid] = anchor
            first[valid] = level[after - np.uint64(1)]
            valid += 1
    kept = np.ones(valid, dtype=np.bool_)
    for i in range(1, valid):
        if anchors[i] - anchors[i - 1] < 39.5 * half:
            for bit in range(2):
                centre = anchors[i] + (3.5 + bit) * spus
                if np.searchsorted(crossings, centre + 0.3 * spus) <= \
                        np.searchsorted(crossings, centre - 0.3 * spus):
                    kept[i] = False
    # Two syncs cannot overlap: a sync-like pattern starting inside the previous sync (its
    # second half continued by a bit without its transition) is data.
    out_anchors = np.empty(valid)
    out_first = np.empty(valid, dtype=np.int8)
    count = 0
    previous = -np.inf
    for i in range(valid):
        if not kept[i]:
            continue
        if anchors[i] - previous >= 5.5 * half:
            out_anchors[count] = anchors[i]
            out_first[count] = first[i]
            count += 1
        previous = anchors[i]
    return out_anchors[:count], out_first[:count]


@kernel
def word_extents(anchors: FloatArray, crossings: FloatArray, silent_after: FloatArray,
                 n: int, half: float) -> tuple[IntArray, FloatArray]:
    """Per anchored word, the index of its first crossing and where its activity stops.

    A word owns what lies at or after its sync's start less a quarter bit, up to the next
    word's; its activity stops at the next silence, the end of the buffer (``n`` samples) or
    the next sync, whichever is first.
    """
    first_owned = np.empty(anchors.size, dtype=np.int64)
    span_end = np.empty(anchors.size)
    first = silent = 0
    for i in range(anchors.size):
        first = walk_to(crossings, anchors[i] - 0.5 * half, first)
        first_owned[i] = first
        silent = walk_to(silent_after, anchors[i], silent)
        end = min(silent_after[silent] if silent < silent_after.size else np.inf, float(n))
        span_end[i] = min(end, anchors[i + 1]) if i + 1 < anchors.size else end
    return first_owned, span_end


@kernel
def unexplained_segments(left: FloatArray, right: FloatArray, anchors: FloatArray,
                 span_end: FloatArray, margin: float, seen: float, limit: float, base: int,
                 join: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The segments no word explains, with ``seen < left < limit``, grouped into bursts
    (neighbours closer than ``join``): each burst's start, end and active time, in samples
    from the capture's start (``base`` is the buffer's).

    A segment is explained when it starts inside its owner word's span: from the word's
    sync start less a quarter bit (``margin``) to its span's end plus the same margin. The
    unexplained ones lie before the first word, or between a word's span and the next word.
    """
    b_start = np.empty(left.size)
    b_end = np.empty(left.size)
    active = np.empty(left.size)
    bursts = 0
    # Where each gap starts and ends only moves forward: found by walking on from the last
    # one (as np.searchsorted(..., side="left") would find it).
    span_stop = owner_start = 0
    for gap in range(anchors.size + 1):
        lo = 0
        if gap > 0:
            span_stop = walk_to(left, span_end[gap - 1] + margin, span_stop)
            lo = max(span_stop, owner_start)
        if gap < anchors.size:
            owner_start = walk_to(left, anchors[gap] - margin, owner_start)
        hi = owner_start if gap < anchors.size else left.size
        for j in range(np.uint64(lo), np.uint64(hi)):  # unsigned: no wrap-around
            if not seen < left[j] < limit:
                continue
            start, end = left[j] + base, right[j] + base
            if bursts == 0 or start - b_end[bursts - 1] > join:
                b_start[bursts] = start
                active[bursts] = 0.0
                bursts += 1
            active[bursts - 1] += end - start
            b_end[bursts - 1] = end
    return b_start[:bursts], b_end[:bursts], active[:bursts]


@kernel
def walk_to(sorted_times: FloatArray, value: float, start: int) -> int:
    """The first index at or after ``start`` whose time is not below ``value`` (the size if
    none): what walking on from ``start`` finds, as ``np.searchsorted(..., side="left")``
    would from there. Strides doubling from ``start``, then a bisection: the distances
    walked here are a few dozen crossings, the arrays a hundred thousand.
    """
    size = sorted_times.size
    probe = start
    stride = 1
    # Unsigned indices: numba then leaves out the wrap-around of negative ones.
    while probe < size and sorted_times[np.uint64(probe)] < value:
        start = probe + 1
        probe += stride
        stride *= 2
    stop = min(probe, size)
    while start < stop:
        middle = (start + stop) // 2
        if sorted_times[np.uint64(middle)] < value:
            start = middle + 1
        else:
            stop = middle
    return start
