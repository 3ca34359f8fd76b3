"""Manchester-II encoder: words in, capture samples out (the format of the bit-level seam).

A capture is one byte per sample: bit0 = bus A RX (line positive), bit1 = bus A RXB (line
negative), bit2 = bus B RX, bit3 = bus B RXB; both bits 0 means no signal. The encoder is the
test suite's source of waveforms and the loopback bus's bit-level path, so it can impair the
signal (bit-rate error, zero-crossing jitter, a dead band around crossings, single-sample
glitches) and inject word faults (wrong parity, a bit without its mid-bit transition, a word
bits short or long, an inverted sync).

Waveform (MIL-STD-1553B 4.3.3): a word is 40 half-bit cells of 0.5 µs — the sync is three cells
of one polarity then three of the other (command/status: positive first; data: negative first),
then 17 bits (16 data bits MSB first, then odd parity), a logic 1 being a positive cell then a
negative one. Sample ``n`` is the line state at ``n / rate`` seconds.

Everything is vectorized: words become arrays of cells, cells become change points, and change
points become samples by ``np.repeat``. Only words with an injected fault take a Python step.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from drivers.errors import EncodeError
from drivers.mil1553.wordbatch import BUS_A, BUS_B, SYNC_CMD, WORD_TIME_NS, WordBatch
from drivers.mil1553.words import parity_bit

HALF_BIT_NS = 500.0
CELLS_PER_WORD = 40
MIN_RATE_HZ = 2e6
MAX_RATE_HZ = 500e6

RX_BITS = {BUS_A: (0x01, 0x02), BUS_B: (0x04, 0x08)}
"""Per bus, the capture bits of (RX: line positive, RXB: line negative)."""


@dataclass(frozen=True, slots=True)
class WordFault:
    """Faults injected into one word. Each one must be flagged by a correct decoder.

    ``bit_count`` adds (> 0) or removes (< 0) bits at the end of the word; added bits are
    valid Manchester bits. ``no_transition`` is the index (0-16, 16 = parity) of a bit sent
    without its mid-bit transition. ``inverted_sync`` sends the other sync type: a valid
    word of the wrong type, which only the message level can flag.
    """

    parity: bool = False
    no_transition: int | None = None
    bit_count: int = 0
    inverted_sync: bool = False

    def __post_init__(self) -> None:
        if self.no_transition is not None and not 0 <= self.no_transition <= 16:
            raise EncodeError(f"no_transition bit {self.no_transition} is outside 0-16")
        if not -17 <= self.bit_count <= 16:
            raise EncodeError(f"bit_count {self.bit_count} is outside -17..16")

    @property
    def any(self) -> bool:
        return (self.parity or self.no_transition is not None or self.bit_count != 0
                or self.inverted_sync)


NO_FAULT = WordFault()


@dataclass(frozen=True, slots=True)
class Impairments:
    """Signal impairments applied to every word (the receiver tolerances of the standard are
    ±150 ns zero-crossing deviation and ±0.1 % bit rate; a dead band is the time both
    receiver outputs are low around a crossing)."""

    rate_error: float = 0.0
    """Fractional bit-rate error: +1e-3 sends bits 0.1 % long (a slow transmitter clock)."""
    jitter_ns: float = 0.0
    """Each polarity crossing is displaced by a uniform draw in ±jitter_ns."""
    dead_band_ns: float = 0.0
    """Both receiver outputs low for this long, centred on each crossing."""
    glitch_probability: float = 0.0
    """Chance per word of one single-sample glitch (the sample's polarity inverted)."""
    seed: int | None = 0
    rng: np.random.Generator | None = field(default=None, compare=False)
    """A generator to draw from (overrides ``seed``), for streams encoded in pieces."""

    def generator(self) -> np.random.Generator:
        return self.rng if self.rng is not None else np.random.default_rng(self.seed)


CLEAN = Impairments()


def _word_cells(values: npt.NDArray[np.uint16], syncs: npt.NDArray[np.uint8]
                ) -> npt.NDArray[np.int8]:
    """The 40 half-bit cell levels (+1/-1) of clean words, one row per word."""
    n = values.size
    cells = np.empty((n, CELLS_PER_WORD), dtype=np.int8)
    first = np.where(syncs == SYNC_CMD, 1, -1).astype(np.int8)
    cells[:, 0:3] = first[:, None]
    cells[:, 3:6] = -first[:, None]
    shifts = np.arange(15, -1, -1, dtype=np.uint16)
    bits = ((values[:, None] >> shifts) & 1).astype(np.int8)
    bits = np.concatenate([bits, parity_bit(values).astype(np.int8)[:, None]], axis=1)
    level = bits * 2 - 1
    cells[:, 6::2] = level
    cells[:, 7::2] = -level
    return cells


def _faulted_cells(value: int, sync: int, fault: WordFault) -> npt.NDArray[np.int8]:
    """Cells of one word with its faults applied (variable length for bit-count faults)."""
    if fault.inverted_sync:
        sync ^= 1
    cells: npt.NDArray[np.int8] = _word_cells(np.array([value], np.uint16),
                                              np.array([sync], np.uint8))[0].copy()
    if fault.parity:
        cells[38:40] = -cells[38:40]
    if fault.no_transition is not None:
        k = 6 + 2 * fault.no_transition
        cells[k + 1] = cells[k]
    if fault.bit_count < 0:
        cells = cells[: CELLS_PER_WORD + 2 * fault.bit_count]
    elif fault.bit_count > 0:
        extra = np.tile(np.array([1, -1, -1, 1], np.int8), fault.bit_count)[: 2 * fault.bit_count]
        cells = np.concatenate([cells, extra])
    return cells


def encode_words(words: WordBatch, sample_rate: float, *,
                 impairments: Impairments = CLEAN,
                 faults: Sequence[WordFault] | None = None,
                 duration_ns: int | None = None) -> npt.NDArray[np.uint8]:
    """Encode a batch of words (:data:`~drivers.mil1553.wordbatch.WORD_DTYPE`, using ``t_ns``,
    ``bus``, ``sync`` and ``value``) into capture samples at ``sample_rate`` (Hz).

    Words on one bus must not overlap (one transmitter at a time). The capture runs from
    t = 0 to ``duration_ns`` (default: 4 µs after the last word).
    """
    if not MIN_RATE_HZ <= sample_rate <= MAX_RATE_HZ:
        raise EncodeError(f"sample rate {sample_rate:g} Hz is outside "
                          f"{MIN_RATE_HZ:g}-{MAX_RATE_HZ:g}")
    if faults is not None and len(faults) != len(words):
        raise EncodeError(f"{len(faults)} faults for {len(words)} words")
    if words.size and int(words["t_ns"].min()) < 0:
        raise EncodeError("word times must be >= 0")
    rng = impairments.generator()
    half = HALF_BIT_NS * (1.0 + impairments.rate_error)
    end_ns = 0.0
    if words.size:
        end_ns = float(words["t_ns"].max()) + (WORD_TIME_NS + 16 * 1000) * (1 + abs(
            impairments.rate_error))
    total_ns = float(duration_ns) if duration_ns is not None else end_ns + 4000.0
    n_samples = int(np.floor(total_ns * sample_rate / 1e9)) + 1
    capture = np.zeros(n_samples, dtype=np.uint8)
    for bus in (BUS_A, BUS_B):
        sel = np.flatnonzero(words["bus"] == bus)
        if sel.size == 0:
            continue
        bus_words = words[sel]
        bus_faults = [faults[int(i)] for i in sel] if faults is not None else None
        times, levels = _change_points(bus_words, bus_faults, half, impairments, rng)
        level = _rasterize(times, levels, n_samples, sample_rate)
        if impairments.glitch_probability > 0:
            _add_glitches(level, bus_words["t_ns"], impairments.glitch_probability,
                          sample_rate, rng)
        pos_bit, neg_bit = RX_BITS[bus]
        capture |= np.where(level > 0, pos_bit, np.where(level < 0, neg_bit, 0)).astype(np.uint8)
    return capture


def _change_points(words: WordBatch, faults: Sequence[WordFault] | None, half: float,
                   imp: Impairments, rng: np.random.Generator
                   ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]:
    """Times (ns) at which the line level changes, and the level from then on, for one bus."""
    order = np.argsort(words["t_ns"], kind="stable")
    words = words[order]
    if faults is not None:
        faults = [faults[i] for i in order]
    cells_list: list[npt.NDArray[np.int8]] = []
    clean = _word_cells(words["value"].astype(np.uint16), words["sync"].astype(np.uint8))
    if faults is None or not any(f.any for f in faults):
        lengths = np.full(words.size, CELLS_PER_WORD)
        flat = clean.reshape(-1)
    else:
        for i, f in enumerate(faults):
            cells_list.append(_faulted_cells(int(words["value"][i]), int(words["sync"][i]), f)
                              if f.any else clean[i])
        lengths = np.array([c.size for c in cells_list])
        flat = np.concatenate(cells_list)
    t0 = words["t_ns"].astype(np.float64)
    word_end = t0 + lengths * half
    if np.any(t0[1:] < word_end[:-1] - 1e-6):
        k = int(np.flatnonzero(t0[1:] < word_end[:-1] - 1e-6)[0])
        raise EncodeError(f"words at {int(t0[k])} ns and {int(t0[k + 1])} ns overlap on one bus")
    word_of_cell = np.repeat(np.arange(words.size), lengths)
    first_cell = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    cell_in_word = np.arange(flat.size) - first_cell[word_of_cell]
    cell_time = t0[word_of_cell] + cell_in_word * half
    # Keep the cells where the level changes (a word's first cell always starts a level).
    starts = np.ones(flat.size, dtype=bool)
    starts[1:] = (flat[1:] != flat[:-1]) | (cell_in_word[1:] == 0)
    crossing = starts & (cell_in_word > 0)
    times = cell_time[starts]
    levels = flat[starts]
    is_cross = crossing[starts]
    if imp.jitter_ns > 0:
        times = times + np.where(is_cross, rng.uniform(-imp.jitter_ns, imp.jitter_ns, times.size),
                                 0.0)
    if imp.dead_band_ns > 0:
        # Split each crossing into "line goes quiet" then "line takes the new polarity".
        quiet = times[is_cross] - imp.dead_band_ns / 2
        times = np.where(is_cross, times + imp.dead_band_ns / 2, times)
        # Quiet points first: where a dead band rounds to nothing, the new level must win.
        times = np.concatenate([quiet, times])
        levels = np.concatenate([np.zeros(quiet.size, np.int8), levels])
    # Each word returns the line to idle at its end; listed first so that, where the next
    # word starts at that very instant, the stable sort lets the new level win.
    times = np.concatenate([word_end, times])
    levels = np.concatenate([np.zeros(word_end.size, np.int8), levels])
    order = np.argsort(times, kind="stable")
    return times[order], levels[order]


def _rasterize(times: npt.NDArray[np.float64], levels: npt.NDArray[np.int8], n_samples: int,
               sample_rate: float) -> npt.NDArray[np.int8]:
    """Sample a piecewise-constant line level at ``n / sample_rate``."""
    first_sample = np.ceil(times * sample_rate / 1e9 - 1e-9).astype(np.int64)
    first_sample = np.clip(first_sample, 0, n_samples)
    bounds = np.concatenate([[0], first_sample, [n_samples]])
    counts = np.diff(bounds)
    values = np.concatenate([[0], levels]).astype(np.int8)
    out: npt.NDArray[np.int8] = np.repeat(values, np.maximum(counts, 0))
    return out


def _add_glitches(level: npt.NDArray[np.int8], t0_ns: npt.NDArray[np.int64], probability: float,
                  sample_rate: float, rng: np.random.Generator) -> None:
    """Invert one sample inside a random subset of words (in place)."""
    hit = rng.random(t0_ns.size) < probability
    when = t0_ns[hit] + rng.uniform(0, WORD_TIME_NS, int(hit.sum()))
    idx = np.clip(np.round(when * sample_rate / 1e9).astype(np.int64), 0, level.size - 1)
    level[idx] = -level[idx]
