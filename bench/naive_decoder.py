"""A naive per-sample Manchester-II decoder: the baseline ``bench/codec.py`` measures against.

It is what one writes first: a Python loop over every sample that times the runs of one line
level and turns them into half-bit cells (0.5 µs each), then looks for the sync pattern (three
cells of one polarity, three of the other) and reads 17 bits after it. It handles clean
captures only, which is all a speed baseline needs; the benchmark checks that it agrees with
the real decoder on the benchmark's capture.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt


def decode_naive(samples: npt.NDArray[np.uint8], sample_rate: float
                 ) -> list[tuple[int, int, int, int]]:
    """Words as ``(t_ns, bus, sync, value)``, sorted by time."""
    half = sample_rate * 0.5e-6
    words: list[tuple[int, int, int, int]] = []
    for bus in (0, 1):
        pos_bit, neg_bit = (1, 2) if bus == 0 else (4, 8)
        level, run_start, burst_start = 0, 0, 0
        cells: list[int] = []
        for i, byte in enumerate(samples.tolist()):
            new = (1 if byte & pos_bit else 0) - (1 if byte & neg_bit else 0)
            if new == level:
                continue
            if level != 0:
                cells.extend([level] * round((i - run_start) / half))
            if new == 0:
                words += _parse(cells, burst_start, bus, half, sample_rate)
                cells = []
            elif level == 0:
                burst_start = i
            level, run_start = new, i
        if level != 0:
            cells.extend([level] * round((len(samples) - run_start) / half))
            words += _parse(cells, burst_start, bus, half, sample_rate)
    words.sort()
    return words


def _parse(cells: list[int], start: int, bus: int, half: float, rate: float
           ) -> list[tuple[int, int, int, int]]:
    out = []
    p = 0
    while p + 40 <= len(cells):
        first = cells[p]
        if cells[p:p + 3] == [first] * 3 and cells[p + 3:p + 6] == [-first] * 3:
            value = 0
            for k in range(16):
                value = value << 1 | (1 if cells[p + 6 + 2 * k] > 0 else 0)
            t_ns = round((start + p * half) / rate * 1e9)
            out.append((t_ns, bus, 1 if first > 0 else 0, value))
            p += 40
        else:
            p += 1
    return out
