"""Reading anchored words: bits, length and error flags from the crossings on their grid.

Once a word's grid is fixed (its *anchor*, the sync's start, in samples), each crossing goes
to the nearest half-bit slot, and crossings are counted per slot and direction, one word
after another in a compiled kernel (a loop over each word's few dozen crossings, where numpy
needed a dozen passes over all of them and a table of every word's slots). A good bit has
exactly one crossing at its middle slot and at most one at its start slot; a missing mid-bit
transition leaves the middle empty, a glitch adds a pair. Each bit is then checked on its own:
following the line's polarity from the sync's second half through every counted crossing,
its two halves must be opposite (the mid-bit transition) and every crossing must go to the
other polarity; the bit is its first half (positive = 1). Anything else flags the word
``manchester``: a bit is never guessed from a crossing the line's halves do not confirm, so a
misread bit cannot hide behind a parity fault. Where activity stops (or
the next sync starts) gives the number of bits sent: fewer than 17 is ``bit_count_low``, more
is ``bit_count_high``. Parity is odd over 17 bits.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.jit import kernel
from drivers.mil1553.edges import FloatArray, Int8Array, IntArray
from drivers.mil1553.wordbatch import (
    ERR_BIT_COUNT_HIGH,
    ERR_BIT_COUNT_LOW,
    ERR_MANCHESTER,
    ERR_PARITY,
    SYNC_CMD,
    SYNC_DATA,
    WordBatch,
    empty_words,
)

FIRST_SLOT = 6
"""Half-bit slot of bit 0's first half (slots 0-5 are the sync)."""
BIT_SLOTS = 34
"""Slots 6-39: the first and second half of bits 0-16."""
BITS = 17
"""16 data bits and the parity bit."""


def read_words(crossings: FloatArray, crossing_level: Int8Array, anchors: FloatArray,
               first_owned: IntArray, stop: FloatArray, first_level: Int8Array,
               rows: IntArray, *, half: float, base: int, sample_rate: float) -> WordBatch:
    """Bits, length and errors of the anchored words ``rows`` (``bus`` left 0).

    Word ``i`` owns the crossings from ``first_owned[i]`` up to the next word's (the last
    one, to the end); ``stop[i]`` is where its activity ends (samples, like ``anchors``);
    ``base`` is the sample index of the buffer's start in the capture, for the times in ns.
    """
    words = empty_words(rows.size)
    if rows.size == 0:
        return words
    t_ns, end_ns, sync, value, errors = _read(crossings, crossing_level, anchors, first_owned,
                                              stop, first_level, rows, half, base,
                                              sample_rate)
    words["t_ns"] = t_ns
    words["end_ns"] = end_ns
    words["sync"] = sync
    words["value"] = value
    words["errors"] = errors
    return words


@kernel
def _read(crossings: FloatArray, crossing_level: Int8Array, anchors: FloatArray,
          first_owned: IntArray, stop: FloatArray, first_level: Int8Array, rows: IntArray,
          half: float, base: int, sample_rate: float
          ) -> tuple[IntArray, IntArray, npt.NDArray[np.uint8], npt.NDArray[np.uint16],
                     npt.NDArray[np.uint16]]:
    """The fields of the words ``rows`` (see :func:`read_words`): each owned crossing goes to
    the nearest half-bit slot, and is counted per slot and direction; crossings outside the
    bit slots are ignored."""
    spus = 2 * half
    t_ns = np.empty(rows.size, dtype=np.int64)
    end_ns = np.empty(rows.size, dtype=np.int64)
    sync = np.empty(rows.size, dtype=np.uint8)
    value = np.empty(rows.size, dtype=np.uint16)
    errors = np.empty(rows.size, dtype=np.uint16)
    falling = np.empty(BIT_SLOTS, dtype=np.int64)
    rising = np.empty(BIT_SLOTS, dtype=np.int64)
    for q in range(rows.size):
        word = rows[q]
        anchor = anchors[word]
        end = first_owned[word + 1] if word + 1 < anchors.size else crossings.size
        falling[:] = 0
        rising[:] = 0
        for j in range(first_owned[word], end):
            slot = np.rint((crossings[j] - anchor) / half)
            if FIRST_SLOT <= slot < FIRST_SLOT + BIT_SLOTS:
                if crossing_level[j] > 0:
                    rising[int(slot) - FIRST_SLOT] += 1
                else:
                    falling[int(slot) - FIRST_SLOT] += 1
        bits_sent = int(np.floor((stop[word] - anchor) / spus - 3 + 0.25))
        present = min(bits_sent, BITS)
        ones = 0
        bits = 0
        # The line's polarity, half-bit by half-bit: the sync's second half, then each
        # crossing counted in a slot takes it to the crossing's new polarity. A bit is read
        # from its two halves, which must be opposite (the mid-bit transition) and each
        # reached consistently (a crossing never goes to the polarity the line already has).
        # Written without branches on the line's data (a mispredicted branch costs more than
        # the arithmetic): a crossing's direction is rising - falling (+1, -1, 0 for none),
        # and a crossing to the polarity the line already has makes their product 1.
        line = -int(first_level[word])
        bad = 0
        for bit in range(BITS):
            start, mid = 2 * bit, 2 * bit + 1
            live = int(bit < present)
            starts = falling[start] + rising[start]
            to_start = rising[start] - falling[start]
            to_mid = rising[mid] - falling[mid]
            bad |= live & (int(starts > 1) | int(falling[mid] + rising[mid] != 1) |
                           int(to_start * line == 1))
            line = to_start + line * (1 - starts)  # the first half (starts is 0 or 1 here)
            bad |= live & int(to_mid * line == 1)
            one = int(falling[mid] > rising[mid])  # = first half positive, in a valid bit
            line = to_mid
            ones += one
            if bit < BITS - 1:
                bits = (bits << 1) | one
        manchester = bad != 0
        flags = ERR_MANCHESTER if manchester else 0
        if bits_sent < BITS:
            flags |= ERR_BIT_COUNT_LOW
        if bits_sent > BITS:
            flags |= ERR_BIT_COUNT_HIGH
        if bits_sent >= BITS and not manchester and ones % 2 == 0:
            flags |= ERR_PARITY
        t_ns[q] = np.int64(np.rint((anchor + base) * 1e9 / sample_rate))
        last_mid = anchor + (3.5 + max(bits_sent, 1) - 1) * spus
        end_ns[q] = np.int64(np.rint((last_mid + base) * 1e9 / sample_rate))
        sync[q] = SYNC_CMD if first_level[word] > 0 else SYNC_DATA
        value[q] = bits
        errors[q] = flags
    return t_ns, end_ns, sync, value, errors
