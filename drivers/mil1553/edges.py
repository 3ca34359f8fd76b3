"""From capture samples to line-level runs and zero crossings, one bus at a time.

The decoder works on edges, never per sample in Python: the only pass over the samples is a
comparison of neighbours and ``flatnonzero``, shared by both buses; everything after works on
runs (a few per microsecond of traffic), and the rare cases (drop-outs, glitches, dead bands)
are found once and then handled on their own few indices.

Terms used here: a *run* is a maximal stretch of samples with one line level (+1 positive,
-1 negative, 0 no signal). A *segment* is a run of +1 or -1. Two segments are *adjacent* when
at most a dead band of silence separates them; a *crossing* is the boundary between two
adjacent segments of opposite polarity, timed at the middle of the dead band. A boundary
to or from a long silence is the start or end of activity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drivers.mil1553.encoder import RX_BITS

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]


def bus_levels(values: npt.NDArray[np.uint8], bus: int) -> npt.NDArray[np.int8]:
    """Line level (+1 positive, -1 negative, 0 none) of one bus for each capture byte:
    RX minus RXB, so both outputs high is no signal (0), as both low is."""
    pos_bit, neg_bit = RX_BITS[bus]
    shift = pos_bit.bit_length() - 1
    shifted = values >> shift if shift else values
    level = (shifted & 1).astype(np.int8)
    level -= (shifted >> (neg_bit.bit_length() - 1 - shift)) & 1
    return level


def byte_changes(samples: npt.NDArray[np.uint8]) -> IntArray:
    """Indices where the capture byte differs from the one before, with 0 first.

    This is the one full pass over the samples that both buses share.
    """
    changed = np.empty(samples.size, dtype=bool)
    changed[:1] = True
    np.not_equal(samples[1:], samples[:-1], out=changed[1:])
    changes: IntArray = np.flatnonzero(changed)
    return changes


def bus_runs(values: npt.NDArray[np.uint8], changes: IntArray, bus: int
             ) -> tuple[IntArray, npt.NDArray[np.int8]]:
    """Run starts and levels of one bus, given the capture bytes at the shared change points
    (``values = samples[changes]``)."""
    levels = bus_levels(values, bus)
    keep = np.empty(levels.size, dtype=bool)
    keep[:1] = True
    np.not_equal(levels[1:], levels[:-1], out=keep[1:])
    return changes[keep], levels[keep]


def clean_runs(starts: IntArray, levels: npt.NDArray[np.int8], n: int, *, dropout_max: int,
               glitch_max: int, missed_pulse_min: int = 0
               ) -> tuple[IntArray, npt.NDArray[np.int8]]:
    """Remove short interruptions inside a run, and restore pulses the sampling missed.

    A silent run of at most ``dropout_max`` samples between two segments of the same polarity
    is a drop-out, and a segment of at most ``glitch_max`` samples between two runs of the same
    level is a glitch: both take their neighbours' level. Dead bands (silence between opposite
    polarities) are kept; they are timed as crossings later.

    At low sample rates a half-bit pulse squeezed by jitter and two dead bands can be shorter
    than a sample and fall between samples: the line then shows silence between two segments
    of the same polarity. With ``missed_pulse_min`` > 0, such a silence of at least that many
    samples (and at most ``dropout_max``) becomes a pulse of the other polarity.

    Only runs short enough to be one of these are examined (one comparison over all runs).
    """
    if levels.size < 3:
        return starts, levels
    # Inner runs (neither the first nor the last) no longer than either limit, between two
    # runs of one level: a dead band (silence between opposite polarities) is not one.
    short = np.flatnonzero((starts[2:] - starts[1:-1] <= max(dropout_max, glitch_max)) &
                           (levels[:-2] == levels[2:])) + 1
    if short.size == 0:
        return starts, levels
    length = starts[short + 1] - starts[short]
    level, before = levels[short], levels[short - 1]
    short_gap = (level == 0) & (before != 0) & (length <= dropout_max)
    missed = short_gap & (length >= missed_pulse_min) if missed_pulse_min > 0 else \
        np.zeros(short.size, dtype=bool)
    glitch = (level != 0) & (length <= glitch_max)
    fix = short[(short_gap & ~missed) | glitch]
    restore = short[missed]
    if fix.size == 0 and restore.size == 0:
        return starts, levels
    levels = levels.copy()
    levels[fix] = levels[fix - 1]
    levels[restore] = -levels[restore - 1]
    keep = np.ones(levels.size, dtype=bool)
    keep[1:] = levels[1:] != levels[:-1]
    return starts[keep], levels[keep]


@dataclass(frozen=True, slots=True)
class Segments:
    """The non-silent runs of one bus with their boundary times (in samples, float).

    ``left[k]``/``right[k]`` are crossing times where the neighbour is adjacent and of the
    other polarity, else the time activity starts/stops. ``adjacent_prev[k]`` says segment k
    begins at a crossing (its ``left`` is one).
    """

    level: npt.NDArray[np.int8]
    left: FloatArray
    right: FloatArray
    adjacent_prev: npt.NDArray[np.bool_]
    crossings: FloatArray
    """Times of all crossings, sorted (the ``left`` of segments that begin at one)."""
    crossing_level: npt.NDArray[np.int8]
    """The polarity each crossing goes to (+1: negative to positive)."""
    silent_after: FloatArray
    """Times at which activity stops (a segment's ``right`` followed by silence), sorted."""


def segments(starts: IntArray, levels: npt.NDArray[np.int8], n: int, *, dead_band_max: int
             ) -> Segments:
    """Group runs into segments and time their boundaries.

    A sample is the line state at its instant; a change happened between two samples, so a
    boundary is timed half a sample before the first sample of the new state, and a crossing
    through a dead band at the middle of the silence. Where two segments touch (no dead
    band), both rules give the same time, so only crossings through a dead band need the
    second one.
    """
    live = levels != 0
    bounds = np.append(starts, n)
    if 16 * np.count_nonzero(live) > 15 * live.size:
        # Few silences (clean traffic): a boolean mask copies long stretches at once.
        s, e, lv = bounds[:-1][live], bounds[1:][live], levels[live]
    else:
        # Dead bands alternate with segments: gathering by index is cheaper than a mask
        # that copies one element at a time.
        index = np.flatnonzero(live)
        s, e, lv = bounds[index], bounds[index + 1], levels[index]
        del index
    del bounds
    adjacent = np.zeros(s.size, dtype=bool)
    silence = e[:-1] - s[1:]  # minus the silence between neighbours (0 where they touch)
    adjacent[1:] = (silence >= -dead_band_max) & (lv[1:] != lv[:-1])
    through = np.flatnonzero(adjacent[1:] & (silence != 0))
    del silence
    left = s - 0.5
    right = e - 0.5
    crossing_at = (e[through] - 1 + s[through + 1]) / 2.0
    del s, e
    left[through + 1] = crossing_at
    right[through] = crossing_at
    ends_activity = np.flatnonzero(~adjacent[1:])
    silent_after = np.append(right[ends_activity], right[-1:])
    return Segments(lv, left, right, adjacent, left[adjacent], lv[adjacent], silent_after)
