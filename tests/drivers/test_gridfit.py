"""The grid fit's bit-parallel circular midrange against a plain per-word computation.

The decoder fits each word's half-bit grid from the phase bins of its crossings. The fast
version (a compiled kernel) works on a 32-bit occupancy mask per word; this checks it against
the definition, computed word by word with sorted bins: the middle of the shortest arc holding
every occupied bin when one widest gap is clear, else the circular mean of the bin counts.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.mil1553.gridfit import CLEAR_GAP, PHASE_BINS, fit_grids


def midrange_by_definition(bins: list[int]) -> float | None:
    """One window's grid offset in half-bits, in [-0.5, 0.5), from first principles (None
    where it is the mean of phases that cancel out, which has no direction to compare)."""
    if not bins:
        return 0.0
    occupied = sorted(set(bins))
    # The gap after each occupied bin to the next one round the circle.
    gaps = [(occupied[(i + 1) % len(occupied)] - b) % PHASE_BINS or PHASE_BINS
            for i, b in enumerate(occupied)]
    widest = max(gaps)
    if gaps.count(widest) == 1 and widest >= CLEAR_GAP * PHASE_BINS:
        before = occupied[gaps.index(widest)]
        # The arc runs from the bin after the gap round to the bin before it.
        middle = (before + 0.5 + (PHASE_BINS + widest) / 2) / PHASE_BINS
    else:
        angles = [2 * math.pi * (b + 0.5) / PHASE_BINS for b in bins]
        sin, cos = sum(map(math.sin, angles)), sum(map(math.cos, angles))
        if math.hypot(sin, cos) < 1e-6:
            return None
        middle = math.atan2(sin, cos) / (2 * math.pi)
    return middle - math.floor(middle + 0.5)


HALF = 4.0
"""A half-bit of 4 samples: a crossing at the middle of each phase bin is then exact."""


def fit_windows(windows: list[list[int]], centres: list[float] | None = None) -> list[float]:
    """Fit windows of phase bins, each bin given as a crossing at its middle, in slots that
    go on round the circle (a window spans several half-bits, as a word does)."""
    centres = centres or [1000.0 * (i + 1) for i in range(len(windows))]
    crossings, lo, hi = [], [], []
    for centre, bins in zip(centres, windows, strict=True):
        lo.append(len(crossings))
        crossings += [centre + HALF * (slot + (b + 0.5) / PHASE_BINS)
                      for slot, b in enumerate(bins)]
        hi.append(len(crossings))
    fitted = fit_grids(np.array(crossings, dtype=np.float64), np.array(lo, dtype=np.int64),
                       np.array(hi, dtype=np.int64), np.array(centres), HALF)
    return [float(f) for f in fitted]


window = st.one_of(
    st.lists(st.integers(0, PHASE_BINS - 1), max_size=40),
    # Realistic words: phases clustered round one bin, a few bins either side.
    st.tuples(st.integers(0, PHASE_BINS - 1), st.integers(0, 12), st.integers(1, 40)).flatmap(
        lambda c: st.lists(st.integers(-c[1], c[1]).map(lambda d, c=c: (c[0] + d) % PHASE_BINS),
                           min_size=c[2], max_size=c[2])),
)


@settings(max_examples=300, deadline=None)
@given(windows=st.lists(window, min_size=1, max_size=30))
def test_fit_equals_the_definition_on_every_window(windows: list[list[int]]) -> None:
    """Every window, including those that tie or cover the circle, in one batch."""
    fitted = fit_windows(windows)
    expected = [midrange_by_definition(w) for w in windows]
    for got, want, w in zip(fitted, expected, windows, strict=True):
        if want is None:
            continue
        # The midrange is exact (multiples of 1/64); the mean agrees to rounding.
        assert abs(got - want) < 1e-12 or abs(abs(got - want) - 1) < 1e-12, (w, got, want)


def test_a_clear_cluster_across_the_wrap_point_gets_its_middle() -> None:
    # Bins 30, 31, 0, 1: the arc straddles the circle's start; its middle is bin 31/0's edge.
    assert fit_windows([[30, 31, 0, 1, 31]]) == [0.0]


def test_phases_all_round_the_circle_fall_back_to_the_mean() -> None:
    dense = list(range(PHASE_BINS)) + [8] * 20
    assert abs(fit_windows([dense])[0] - (8.5 / PHASE_BINS)) < 0.02


def test_crossings_are_binned_relative_to_each_window_centre() -> None:
    # One crossing 0.05 of a half-bit late (bin 1) and one 0.02 early (bin 31), in windows
    # centred 100 samples apart: each window's midrange is its own crossing's bin middle.
    crossings = np.array([10.25, 104.9])
    fitted = fit_grids(crossings, np.array([0, 1]), np.array([1, 2]), np.array([0.0, 100.0]),
                       5.0)
    assert fitted.tolist() == [1.5 / PHASE_BINS, 31.5 / PHASE_BINS - 1]


def test_an_empty_window_fits_nothing() -> None:
    fitted = fit_grids(np.array([1.0, 2.0]), np.array([0, 2]), np.array([0, 2]),
                       np.array([0.0, 5.0]), 5.0)
    assert fitted.tolist() == [0.0, 0.0]
