"""From capture samples to line-level runs and zero crossings, one bus at a time.

The decoder works on edges, never per sample in Python: the only passes over the samples are
a comparison of neighbours and ``flatnonzero``; everything after works on runs (a few per
microsecond of traffic).

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


def _level_table(bus: int) -> npt.NDArray[np.int8]:
    """Byte value -> line level of one bus (both outputs high is not a signal: 0)."""
    pos_bit, neg_bit = RX_BITS[bus]
    table = np.zeros(256, dtype=np.int8)
    for byte in range(256):
        pos, neg = bool(byte & pos_bit), bool(byte & neg_bit)
        table[byte] = 1 if pos and not neg else (-1 if neg and not pos else 0)
    return table


LEVEL_TABLES = {bus: _level_table(bus) for bus in RX_BITS}


def byte_changes(samples: npt.NDArray[np.uint8]) -> IntArray:
    """Indices where the capture byte differs from the one before, with 0 first.

    This is the one full pass over the samples that both buses share.
    """
    changes = np.flatnonzero(samples[1:] != samples[:-1]) + 1
    return np.concatenate([np.zeros(1, np.int64), changes.astype(np.int64)])


def bus_runs(samples: npt.NDArray[np.uint8], changes: IntArray, bus: int
             ) -> tuple[IntArray, npt.NDArray[np.int8]]:
    """Run starts and levels of one bus, given the shared byte change points."""
    levels = LEVEL_TABLES[bus][samples[changes]]
    keep = np.ones(levels.size, dtype=bool)
    keep[1:] = levels[1:] != levels[:-1]
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
    """
    if levels.size < 3:
        return starts, levels
    lengths = np.diff(np.append(starts, n))
    inner = slice(1, -1)
    same_sides = levels[:-2] == levels[2:]
    silent_gap = same_sides & (levels[inner] == 0) & (levels[:-2] != 0)
    short_gap = silent_gap & (lengths[inner] <= dropout_max)
    missed = short_gap & (lengths[inner] >= missed_pulse_min) if missed_pulse_min > 0 else \
        np.zeros(silent_gap.size, dtype=bool)
    dropout = short_gap & ~missed
    glitch = same_sides & (levels[inner] != 0) & (lengths[inner] <= glitch_max)
    fix = np.flatnonzero(dropout | glitch) + 1
    restore = np.flatnonzero(missed) + 1
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

    start: IntArray
    end: IntArray
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
    """Group runs into segments and time their boundaries."""
    ends = np.append(starts[1:], n)
    live = levels != 0
    s, e, lv = starts[live], ends[live], levels[live]
    adjacent = np.zeros(s.size, dtype=bool)
    if s.size > 1:
        adjacent[1:] = (s[1:] - e[:-1] <= dead_band_max) & (lv[1:] != lv[:-1])
    # A sample is the line state at its instant; a change happened between two samples, so
    # a boundary is timed half a sample before the first sample of the new state, and a
    # crossing through a dead band at the middle of the silence.
    left = s - 0.5
    crossing_at = (e[:-1] - 1 + s[1:]) / 2.0
    left[1:] = np.where(adjacent[1:], crossing_at, left[1:])
    right = e - 0.5
    right[:-1] = np.where(adjacent[1:], crossing_at, right[:-1])
    left, right = left.astype(np.float64), right.astype(np.float64)
    ends_activity = np.append(~adjacent[1:], True) if adjacent.size else adjacent
    return Segments(s, e, lv, left, right, adjacent, left[adjacent], lv[adjacent],
                    right[ends_activity])
