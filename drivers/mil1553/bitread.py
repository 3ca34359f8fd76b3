"""Reading anchored words: bits, length and error flags from the crossings on their grid.

Once a word's grid is fixed (its *anchor*, the sync's start, in samples), each crossing goes
to the nearest half-bit slot, one word after another in a compiled kernel (a loop over each
word's few dozen crossings, where numpy needed a dozen passes over all of them and a table of
every word's slots). The slots holding a crossing become one bit mask per direction, and the
checks below are then a few mask operations for all 17 bits at once; a word with two
crossings in one slot is counted slot by slot instead, bit after bit. A good bit has
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


_MIDS = sum(1 << (2 * bit + 1) for bit in range(BITS))
"""Positions of the mid-bit slots in a word's crossing masks (see :func:`_read`)."""
_POSITIONS = FIRST_SLOT + BIT_SLOTS
"""A crossing in slot ``s`` sets bit ``_POSITIONS - s`` of its word's masks: bit 34 is bit
0's first half and bit 1 the parity bit's second half, so the value's bits come out in
order; bit 35 stands for the sync's second half."""
_SYNC_HALF = _POSITIONS - FIRST_SLOT + 1


@kernel
def _read(crossings: FloatArray, crossing_level: Int8Array, anchors: FloatArray,
          first_owned: IntArray, stop: FloatArray, first_level: Int8Array, rows: IntArray,
          half: float, base: int, sample_rate: float
          ) -> tuple[IntArray, IntArray, npt.NDArray[np.uint8], npt.NDArray[np.uint16],
                     npt.NDArray[np.uint16]]:
    """The fields of the words ``rows`` (see :func:`read_words`): each owned crossing goes to
    the nearest half-bit slot; crossings outside the bit slots are ignored.

    A word's crossings become two masks of occupied slots, one per direction. Where no slot
    holds two crossings (a clean or jittered word), every check of the module doc is a few
    operations on the masks, for all 17 bits at once: the line's polarity, followed from the
    sync's second half through the crossings, changes at each one, so two neighbouring
    occupied slots (or two mid-bit slots around an empty start slot) with crossings of the
    same direction are a crossing to the polarity the line already has; an empty mid-bit
    slot is a missing transition. A word with a slot holding two or more crossings (a
    glitch) is read slot by slot, counting them (:func:`_counted_bits`)."""
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
        up = 0
        down = 0
        twice = 0
        # Unsigned indices: numba then leaves out the wrap-around of negative ones, a few
        # instructions per crossing (``j`` is only ever an index).
        for j in range(np.uint64(first_owned[word]), np.uint64(end)):
            slot = np.rint((crossings[j] - anchor) / half)
            if FIRST_SLOT <= slot < FIRST_SLOT + BIT_SLOTS:
                bit = 1 << (_POSITIONS - int(slot))
                twice |= (up | down) & bit
                if crossing_level[j] > 0:
                    up |= bit
                else:
                    down |= bit
        bits_sent = int(np.floor((stop[word] - anchor) / spus - 3 + 0.25))
        present = min(bits_sent, BITS)
        if twice:
            bits, ones, bad = _counted_bits(crossings, crossing_level, first_owned[word], end,
                                            anchor, half, int(first_level[word]), present,
                                            falling, rising)
        else:
            # The sync's second half, opposite to its first, as a crossing before bit 0.
            if first_level[word] > 0:
                down |= 1 << _SYNC_HALF
            else:
                up |= 1 << _SYNC_HALF
            occupied = up | down
            bad = (up & (up >> 1)) | (down & (down >> 1)) | \
                (((up & (up >> 2)) | (down & (down >> 2))) & ~(occupied >> 1) & _MIDS) | \
                (~occupied & _MIDS)
            # The slots of the bits sent: positions 35 - 2 * present to 34.
            live = 0
            if present > 0:
                live = ((1 << _SYNC_HALF) - 1) & ~((1 << (_SYNC_HALF - 2 * present)) - 1)
            bad &= live
            # The bits are the mid-bit slots' falling crossings (first half positive).
            spread = (down >> 3) & 0x55555555
            spread = (spread | (spread >> 1)) & 0x33333333
            spread = (spread | (spread >> 2)) & 0x0F0F0F0F
            spread = (spread | (spread >> 4)) & 0x00FF00FF
            bits = (spread | (spread >> 8)) & 0xFFFF
            ones = down & _MIDS
            ones ^= ones >> 32
            ones ^= ones >> 16
            ones ^= ones >> 8
            ones ^= ones >> 4
            ones ^= ones >> 2
            ones ^= ones >> 1
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


@kernel
def _counted_bits(crossings: FloatArray, crossing_level: Int8Array, begin: int, end: int,
                  anchor: float, half: float, first_level: int, present: int,
                  falling: IntArray, rising: IntArray) -> tuple[int, int, int]:
    """One word's value, number of one bits (parity included) and its manchester flag
    (non-zero: bad), from the crossings ``begin:end`` counted per slot and direction (the
    words of :func:`_read` with a slot holding more than one crossing).

    The line's polarity is followed half-bit by half-bit: the sync's second half, then each
    crossing counted in a slot takes it to the crossing's new polarity. A bit is read from
    its two halves, which must be opposite (the mid-bit transition) and each reached
    consistently (a crossing never goes to the polarity the line already has). Written
    without branches on the line's data: a crossing's direction is rising - falling (+1,
    -1, 0 for none), and a crossing to the polarity the line already has makes their
    product 1.
    """
    falling[:] = 0
    rising[:] = 0
    for j in range(begin, end):
        slot = np.rint((crossings[j] - anchor) / half)
        if FIRST_SLOT <= slot < FIRST_SLOT + BIT_SLOTS:
            if crossing_level[j] > 0:
                rising[int(slot) - FIRST_SLOT] += 1
            else:
                falling[int(slot) - FIRST_SLOT] += 1
    ones = 0
    bits = 0
    line = -first_level
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
    return bits, ones, bad
