"""Damaged words on the line, many at once: the decoder's integrity campaign and tests.

Each word is sent alone in a slot of :data:`SLOT_NS` on bus A (so every decoded word belongs to
the slot it starts in), its start drawn at random within the slot's second microsecond (any
phase against the sample clock), every zero crossing displaced by its own uniform draw in
±``jitter_ns`` (the standard's receiver tolerance is ±150 ns), then one corruption of a
:data:`KINDS` is applied:

``clean``          none.
``half_flip``      one half-bit cell (sync or bit) sent with the wrong polarity.
``parity``         the parity bit inverted (both its halves).
``no_transition``  one bit's second half sent like its first: no mid-bit transition.
``both_high``      both receiver outputs high (no valid signal) for 10-300 ns.
``dropout``        both outputs low for 10-1000 ns.
``truncation``     the word stops after 1-39 of its 40 half-bit cells.
``shifted``        one mid-bit crossing moved by 160-340 ns (beyond the tolerance).

Corruptions that always leave an invalid word (:data:`ALWAYS_INVALID`) must be flagged
whatever is decoded; the others (a glitch between two samples, a crossing moved less than a
quarter bit) may leave a word a receiver can read, and may then be reported clean, but only
with the value sent. :func:`classify` scores a decoder's output that way.

The waveforms are built as arrays (cells, crossing times), not word by word, so that millions
of words take seconds. Only tests and benchmarks import this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drivers.mil1553.encoder import CELLS_PER_WORD, HALF_BIT_NS
from drivers.mil1553.wordbatch import SYNC_CMD, WordBatch
from drivers.mil1553.words import parity_bit

KINDS = ("clean", "half_flip", "parity", "no_transition", "both_high", "dropout",
         "truncation", "shifted")
ALWAYS_INVALID = frozenset({"half_flip", "parity", "no_transition", "truncation"})
SLOT_NS = 26_000
"""Each word's slot: 1-2 µs of lead, the 20 µs word, at least 4 µs of idle line."""
LEAD_NS = 1_000.0

BOTH_HIGH = 2
"""Line state code for both receiver outputs high (bus A: RX and RXB bits set)."""
_STATE_BYTE = np.array([2, 0, 1, 3], dtype=np.uint8)
"""Capture byte per state code + 1: -1 -> RXB, 0 -> none, +1 -> RX, 2 -> both."""


@dataclass(frozen=True, slots=True)
class DamagedWords:
    """One batch of slotted words: what was sent, and the capture that carries it."""

    values: npt.NDArray[np.uint16]
    syncs: npt.NDArray[np.uint8]
    samples: npt.NDArray[np.uint8]
    kind: str


def damaged_words(kind: str, count: int, sample_rate: float, jitter_ns: float,
                  rng: np.random.Generator, dead_band_ns: float = 0.0) -> DamagedWords:
    """``count`` random words, each with one corruption of ``kind``, as a capture of
    ``count`` slots at ``sample_rate`` (bus A; bus B idle). ``jitter_ns`` must not exceed
    150 (a shifted crossing then stays between its neighbours); ``dead_band_ns`` leaves both
    outputs low for that long around each crossing, as a transceiver does."""
    if kind not in KINDS:
        raise ValueError(f"unknown corruption {kind!r}; one of {', '.join(KINDS)}")
    values = rng.integers(0, 1 << 16, count, dtype=np.uint16)
    syncs = rng.integers(0, 2, count, dtype=np.uint8)
    cells = _cells(values, syncs)
    rows = np.arange(count)
    if kind == "half_flip":
        cells[rows, rng.integers(0, CELLS_PER_WORD, count)] *= -1
    elif kind == "parity":
        cells[:, 38:40] *= -1
    elif kind == "no_transition":
        first = 6 + 2 * rng.integers(0, 17, count)
        cells[rows, first + 1] = cells[rows, first]
    elif kind == "truncation":
        keep = rng.integers(1, CELLS_PER_WORD, count)
        cells[np.arange(CELLS_PER_WORD)[None, :] >= keep[:, None]] = 0
    # Boundary k (0-40) starts cell k; boundary 40 ends the word. Crossings are jittered.
    t0 = rows * float(SLOT_NS) + LEAD_NS + rng.uniform(0, LEAD_NS, count)
    bounds = t0[:, None] + np.arange(CELLS_PER_WORD + 1)[None, :] * HALF_BIT_NS
    bounds[:, 1:CELLS_PER_WORD] += rng.uniform(-jitter_ns, jitter_ns,
                                               (count, CELLS_PER_WORD - 1))
    if kind == "shifted":
        mid = 7 + 2 * rng.integers(0, 17, count)
        shift = rng.uniform(160.0, 340.0, count) * rng.choice([-1.0, 1.0], count)
        bounds[rows, mid] = t0 + mid * HALF_BIT_NS + shift
    levels = np.concatenate([cells, np.zeros((count, 1), np.int8)], axis=1)
    state = _rasterize(bounds.reshape(-1), levels.reshape(-1), count * SLOT_NS, sample_rate)
    if dead_band_ns > 0:
        inner = bounds[:, 1:CELLS_PER_WORD][cells[:, 1:] * cells[:, :-1] < 0]
        _overwrite(state, inner - dead_band_ns / 2, inner + dead_band_ns / 2, 0, sample_rate)
    if kind in ("both_high", "dropout"):
        longest = 300.0 if kind == "both_high" else 1000.0
        start = t0 + rng.uniform(0, CELLS_PER_WORD * HALF_BIT_NS, count)
        _overwrite(state, start, start + rng.uniform(10.0, longest, count),
                   BOTH_HIGH if kind == "both_high" else 0, sample_rate)
    return DamagedWords(values, syncs, _STATE_BYTE[state + 1], kind)


def _cells(values: npt.NDArray[np.uint16], syncs: npt.NDArray[np.uint8]
           ) -> npt.NDArray[np.int8]:
    """The 40 half-bit cells (+1/-1) of each word, one row per word."""
    cells = np.empty((values.size, CELLS_PER_WORD), dtype=np.int8)
    first = np.where(syncs == SYNC_CMD, 1, -1).astype(np.int8)
    cells[:, 0:3] = first[:, None]
    cells[:, 3:6] = -first[:, None]
    bits = (values[:, None] >> np.arange(15, -1, -1, dtype=np.uint16)) & 1
    bits = np.concatenate([bits, parity_bit(values)[:, None]], axis=1).astype(np.int8)
    cells[:, 6::2] = 2 * bits - 1
    cells[:, 7::2] = 1 - 2 * bits
    return cells


def _rasterize(times: npt.NDArray[np.float64], levels: npt.NDArray[np.int8], n_samples: int,
               sample_rate: float) -> npt.NDArray[np.int8]:
    """The line state at each sample ``n / sample_rate`` (times in ns, sorted per word)."""
    first = np.clip(np.ceil(times * sample_rate / 1e9 - 1e-9).astype(np.int64), 0,
                    None)
    n = int(np.floor(n_samples * sample_rate / 1e9))
    first = np.minimum(first, n)
    counts = np.diff(np.concatenate([[0], first, [n]]))
    out: npt.NDArray[np.int8] = np.repeat(np.concatenate([[0], levels]).astype(np.int8),
                                          counts)
    return out


def _overwrite(state: npt.NDArray[np.int8], start: npt.NDArray[np.float64],
               end: npt.NDArray[np.float64], code: int, sample_rate: float) -> None:
    """Set the samples within ``[start, end)`` ns of each interval to ``code`` (in place)."""
    lo = np.ceil(start * sample_rate / 1e9 - 1e-9).astype(np.int64)
    hi = np.ceil(end * sample_rate / 1e9 - 1e-9).astype(np.int64)
    mark = np.zeros(state.size + 1, dtype=np.int64)
    np.add.at(mark, np.minimum(lo, state.size), 1)
    np.add.at(mark, np.minimum(hi, state.size), -1)
    state[np.cumsum(mark[:-1]) > 0] = code


@dataclass(frozen=True, slots=True)
class Outcome:
    """Per sent word, what the decoder made of it (boolean arrays, one entry per word)."""

    clean_wrong: npt.NDArray[np.bool_]
    """Some word reported clean in its slot that is not the word sent (or the word sent was
    invalid, or two clean words came out of one)."""
    clean_right: npt.NDArray[np.bool_]
    """Exactly the word sent, reported clean (extra flagged activity aside)."""
    flagged: npt.NDArray[np.bool_]
    """Only flagged words in its slot."""
    lost: npt.NDArray[np.bool_]
    """Nothing at all reported in its slot."""


def classify(batch: DamagedWords, decoded: WordBatch) -> Outcome:
    """Score ``decoded`` (the decoder's words for ``batch.samples``) word by word."""
    n = batch.values.size
    slot = np.clip(decoded["t_ns"] // SLOT_NS, 0, n - 1).astype(np.int64)
    clean = decoded["errors"] == 0
    right = clean & (decoded["value"] == batch.values[slot]) & \
        (decoded["sync"] == batch.syncs[slot])
    if batch.kind in ALWAYS_INVALID:
        right[:] = False
    reported = np.bincount(slot, minlength=n) > 0
    clean_count = np.bincount(slot, weights=clean, minlength=n)
    right_count = np.bincount(slot, weights=right, minlength=n)
    clean_right = (clean_count == 1) & (right_count == 1)
    clean_wrong = (clean_count > 0) & ~clean_right
    flagged = reported & (clean_count == 0)
    return Outcome(clean_wrong, clean_right, flagged, ~reported)
