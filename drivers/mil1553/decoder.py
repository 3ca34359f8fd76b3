"""Streaming Manchester-II decoder: capture samples in, word batches out.

Feed it chunks of any size (a chunk may split a word anywhere); the words come out once they
are complete, and :meth:`ManchesterDecoder.flush` finishes the capture. The result is the same
as one call on the whole capture: a sync is judged only with 45 µs of line after it, the end
of a buffer is decoded again with the next samples, and what was judged is never re-emitted.

How a word is found and read. The one pass over the samples finds where the capture byte
changes (:mod:`drivers.mil1553.edges`); every later step works on those edges, a few per
microsecond of traffic, in compiled kernels (:mod:`drivers.jit`): a loop over the edges
costs one pass where numpy needed a dozen, each allocating and paying its fixed cost. This
module keeps the streaming state between buffers and calls the kernels once per buffer.

1. *Sync.* A crossing with at least ~1 µs of one polarity before it and of the other after it
   is a sync candidate (data bits never hold a level for more than 1 µs)
   (:mod:`drivers.mil1553.syncs`).
2. *Anchor.* Every crossing of a word lies near a multiple of the 0.5 µs half-bit from the
   sync's start, each displaced by its own jitter. The middle of the shortest arc of the
   0.5 µs circle that holds all the crossings' phases (the circular midrange) fixes the grid
   so that no crossing is further from its slot than half their spread, even when every
   crossing is off by ±150 ns; where the phases cover most of the circle (low sample rates
   quantize them) the circular mean takes over (:mod:`drivers.mil1553.gridfit`).
3. *Validation.* A real sync holds its level for three half-bits on each side: the segment
   before the middle crossing must start at or before grid slot 0 and the one after it end at
   or after slot 6; anything else (a long data run) is not a sync.
4. *Bits.* Crossings are counted per half-bit slot. A good bit has exactly one crossing at
   its middle slot and at most one at its start slot, and its two halves, followed from the
   sync's polarity through those crossings, are opposite (positive then negative = 1); a
   missing mid-bit transition leaves the middle empty, a glitch adds a pair. Anything else is
   flagged ``manchester`` (:mod:`drivers.mil1553.bitread`): no bit is guessed, and a half-bit
   no sample showed (silence between two runs of one polarity) is never filled in.
5. *Length.* Where activity stops (or the next sync starts) gives the number of bits sent:
   fewer than 17 is ``bit_count_low``, more is ``bit_count_high``. Parity is odd over 17 bits.
6. *Leftovers.* Activity that no valid sync accounts for (noise, a mangled sync) is reported
   as a word flagged ``sync`` at the time it starts, so nothing on the line vanishes silently.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drivers.errors import SampleRateError
from drivers.mil1553.bitread import read_words
from drivers.mil1553.edges import (
    FloatArray,
    Segments,
    Workspace,
    line_segments,
    thread_workspace,
)
from drivers.mil1553.syncs import find_syncs, unexplained_segments, word_extents
from drivers.mil1553.wordbatch import (
    BUS_A,
    BUS_B,
    ERR_SYNC,
    SYNC_DATA,
    WordBatch,
    concat_words,
    empty_words,
    take_words,
)


@dataclass(frozen=True, slots=True)
class DecoderSettings:
    """Tolerances, in µs unless named otherwise. The defaults accept the standard's receiver
    tolerances (±150 ns crossing deviation, ±0.1 % bit rate) plus a 100 ns dead band with room
    to spare, at 8-50 MS/s."""

    sync_half_min_us: float = 0.95
    """Shortest level held on each side of a sync candidate's middle crossing."""
    sync_span_min_us: float = 2.5
    """Shortest span of both sides together (3 µs nominal, 2 µs for two long data runs)."""
    dead_band_max_us: float = 0.3
    """Longest silence between opposite polarities that still counts as a crossing."""
    burst_join_us: float = 2.0
    """Unexplained activity closer than this is one burst (one ``sync``-flagged word)."""
    burst_min_us: float = 0.5
    """Unexplained activity shorter than this in total is ignored as line noise."""
    glitch_filter: bool | None = None
    """Remove single-sample glitches; None = on when a sample is at most 50 ns (>= 20 MS/s),
    where no legitimate segment can be a single sample."""


MIN_DECODE_RATE_HZ = 10e6
"""The slowest capture decoded. A receiver must accept crossings ±150 ns off (MIL-STD-1553B),
and a transceiver's receiver outputs are both low for up to ~100 ns around each crossing, so
a half-bit can show its polarity for only 500 - 2 x 150 - 100 = 100 ns: a sample every 100 ns
or less is needed for every half-bit to be seen in at least one sample. Slower, a half-bit
falls between samples and a decoder can only guess it (at 2-8 MS/s guessed bits came out as
clean words with wrong values), so slower captures are refused (:class:`SampleRateError`)."""
MAX_DECODE_RATE_HZ = 200e6
"""The fastest capture decoded: the fastest the integrity campaign (bench/word_integrity.py)
measured; faster captures are refused the same way (decimate them)."""

BLOCK_SAMPLES = 1 << 20
"""Largest piece of a chunk decoded at once (see :meth:`ManchesterDecoder.feed`)."""


class ManchesterDecoder:
    """Decode a capture stream (DESIGN.md's bit-level format) into words, both buses at once.

    >>> from drivers.mil1553.wordbatch import make_words
    >>> from drivers.mil1553.encoder import encode_words
    >>> samples = encode_words(make_words([(1000, 0, 1, 0x2822)]), 10e6)
    >>> dec = ManchesterDecoder(10e6)
    >>> words = np.concatenate([dec.feed(samples), dec.flush()])
    >>> hex(int(words["value"][0])), int(words["t_ns"][0]), int(words["errors"][0])
    ('0x2822', 958, 0)

    (The sync starts at 1000 ns; at 10 MS/s a change is only known to within a 100 ns
    sample, and is timed half a sample before the first sample that shows it.)
    """

    def __init__(self, sample_rate: float, settings: DecoderSettings | None = None) -> None:
        if not MIN_DECODE_RATE_HZ <= sample_rate <= MAX_DECODE_RATE_HZ:
            raise SampleRateError(
                f"sample rate {sample_rate / 1e6:g} MS/s is not supported: the decoder needs "
                f"{MIN_DECODE_RATE_HZ / 1e6:g}-{MAX_DECODE_RATE_HZ / 1e6:g} MS/s to see every "
                f"half-bit (see docs/codec.md)")
        self.sample_rate = float(sample_rate)
        self.settings = settings or DecoderSettings()
        spus = self.sample_rate / 1e6
        self._spus = spus
        self._half = spus / 2
        # A word is decided in a buffer when its sync starts at least this long before the
        # buffer's end: its 20 µs, and the grid fit of the next word's sync (which ends it),
        # must be whole in the buffer for the result not to depend on where chunks end.
        self._horizon = math.ceil(45 * spus)
        # The undecided part is decoded again with the next samples, with enough before it
        # for the sync candidates its syncs are checked against (the previous word's, up to
        # 20 µs back, and the one before that for overlaps).
        self._tail = self._horizon + math.ceil(30 * spus)
        self._min_batch = math.ceil(64 * spus)
        glitch = self.settings.glitch_filter
        if glitch is None:
            glitch = self.sample_rate >= 20e6
        self._glitch_max = 1 if glitch else 0
        self._dropout_max = max(1, math.floor(self.settings.dead_band_max_us * spus))
        self._pending = np.zeros(0, dtype=np.uint8)
        """The samples not yet decoded for good: the last buffer's tail, and chunks too small
        to decode yet."""
        self._base = 0
        self._last_sync = {BUS_A: -math.inf, BUS_B: -math.inf}
        self._last_burst = {BUS_A: -math.inf, BUS_B: -math.inf}
        self._covered_until = {BUS_A: -math.inf, BUS_B: -math.inf}
        self._judged_until = {BUS_A: -math.inf, BUS_B: -math.inf}
        self._open_burst: dict[int, tuple[float, float, float]] = {}
        self._held = empty_words()
        self._complete_until = -math.inf
        self._decided_until = -math.inf
        """Sample index (from capture start) before which every sync has been judged."""
        self.samples_seen = 0

    # --- public API --------------------------------------------------------------------
    def feed(self, samples: npt.NDArray[np.uint8] | bytes) -> WordBatch:
        """Add samples; return the words completed so far (sorted by time)."""
        chunk = np.frombuffer(samples, dtype=np.uint8) if isinstance(samples, bytes) else \
            np.asarray(samples, dtype=np.uint8)
        if chunk.size <= BLOCK_SAMPLES:
            return self._feed_block(chunk)
        # Streaming gives the same words as one call, so a large chunk (a whole file) is
        # decoded in blocks: the working arrays stay a few MB, whatever the chunk's size.
        return concat_words([self._feed_block(chunk[start:start + BLOCK_SAMPLES])
                             for start in range(0, chunk.size, BLOCK_SAMPLES)])

    def _feed_block(self, chunk: npt.NDArray[np.uint8]) -> WordBatch:
        self.samples_seen += chunk.size
        size = self._pending.size + chunk.size
        if size < self._min_batch + self._tail:
            self._pending = np.concatenate([self._pending, chunk])
            return empty_words()
        # The buffer (the pending samples, then the chunk) is assembled in the thread's
        # workspace, so that a decoder keeps only its small tail between calls.
        work = thread_workspace()
        buf = work.take("samples", size, np.uint8)
        buf[:self._pending.size] = self._pending
        buf[self._pending.size:] = chunk
        words = self._decode(buf, size - self._horizon, work)
        self._complete_until = (self._base + size - self._horizon) * 1e9 / self.sample_rate
        keep_from = size - self._tail
        self._base += keep_from
        self._pending = buf[keep_from:].copy()
        return self._release(words)

    def flush(self) -> WordBatch:
        """End of capture: decode what is left. A word cut off by the end is flagged."""
        real = self._pending.size
        padded = np.concatenate([self._pending, np.zeros(self._tail, dtype=np.uint8)])
        words = self._decode(padded, real, thread_workspace(), final=True)
        self._complete_until = math.inf
        self._base += real
        self._pending = np.zeros(0, dtype=np.uint8)
        return self._release(words)

    def _release(self, words: WordBatch) -> WordBatch:
        """Release words in time order across calls: a noise burst still open on one bus
        holds back the other bus's later words until it is reported."""
        held = _in_time_order(concat_words([self._held, words]))
        if not self._open_burst:
            self._held = empty_words()
            return held
        limit = min(start for start, _, _ in self._open_burst.values()) * 1e9 / self.sample_rate
        cut = int(np.searchsorted(held["t_ns"], limit, side="left"))
        self._held = held[cut:]
        return held[:cut]

    @property
    def complete_until_ns(self) -> float:
        """Every word that starts before this time (ns) has been returned: the horizon to
        give a message assembler. ``inf`` after :meth:`flush`."""
        if self._open_burst:
            first_open = min(start for start, _, _ in self._open_burst.values())
            return min(self._complete_until, first_open * 1e9 / self.sample_rate)
        return self._complete_until

    def decode_all(self, samples: npt.NDArray[np.uint8]) -> WordBatch:
        """Decode a whole capture in one call (``feed`` then ``flush``)."""
        return concat_words([self.feed(samples), self.flush()])

    # --- internals -----------------------------------------------------------------------
    def _decode(self, buf: npt.NDArray[np.uint8], horizon: int, work: Workspace,
                final: bool = False) -> WordBatch:
        out = [self._decode_bus(buf, bus, horizon, final, work)
               for bus in (BUS_A, BUS_B)]
        self._decided_until = self._base + horizon
        return _in_time_order(concat_words(out))

    def _decode_bus(self, buf: npt.NDArray[np.uint8], bus: int, horizon: int, final: bool,
                    work: Workspace) -> WordBatch:
        spus = self._spus
        n = buf.size
        seg = line_segments(buf, bus, work, dropout_max=self._dropout_max,
                            glitch_max=self._glitch_max,
                            dead_band_max=self._dropout_max,
                            half_min=self.settings.sync_half_min_us * spus,
                            span_min=self.settings.sync_span_min_us * spus)
        if seg.level.size == 0:
            return empty_words()
        anchors, first_level = find_syncs(seg, self._half)
        # Only words whose sync lies before the horizon are complete in this buffer; the
        # ones already emitted from an earlier buffer come again in the kept tail: skip them.
        absolute = anchors + self._base
        decided = anchors < horizon
        # A sync before the previous buffer's horizon was judged there (and emitted or
        # rejected), whatever this buffer, with less context at its start, makes of it.
        fresh = np.flatnonzero(decided & (absolute >= self._decided_until) &
                               (absolute > self._last_sync[bus] + 2 * self._spus))
        if decided.any():
            self._last_sync[bus] = max(self._last_sync[bus], float(absolute[decided].max()))
        first_owned, span_end = word_extents(anchors, seg.crossings, seg.silent_after, n,
                                             self._half)
        words = read_words(seg.crossings, seg.crossing_level, anchors, first_owned, span_end,
                           first_level, fresh, half=self._half, base=self._base,
                           sample_rate=self.sample_rate)
        words["bus"] = bus
        bursts = self._bursts(seg, anchors, span_end,
                              horizon=math.inf if final else horizon, bus=bus)
        # Words the next buffer decodes again (their sync in its kept tail) cover their
        # activity there; the others' coverage is remembered.
        settled = anchors < (horizon if final else min(horizon, n - self._tail))
        if settled.any():
            self._covered_until[bus] = max(self._covered_until[bus],
                                           float(span_end[settled].max()) + self._base)
        return concat_words([words, bursts])

    def _bursts(self, seg: Segments, anchors: FloatArray, words_span_end: FloatArray,
                horizon: float, bus: int) -> WordBatch:
        """Activity no valid sync explains, as ``sync``-flagged words (see module doc).

        Only activity well before the horizon is judged (later segments may still turn out
        to be a word whose sync lies past it). A burst still going on there is held open and
        its start remembered, so a burst longer than the kept tail comes out once, whole, as
        it would from a single call.
        """
        base = self._base
        join = self.settings.burst_join_us * self._spus
        limit = horizon - self._spus
        # Activity before the last buffer's limit was judged there (reported, held open, or
        # covered), and so was what earlier words cover.
        seen = max(self._last_burst[bus], self._covered_until[bus],
                   self._judged_until[bus]) - base
        self._judged_until[bus] = math.nextafter(limit + base, -math.inf)  # left >= limit
        b_start, b_end, active = unexplained_segments(
            seg.left, seg.right, anchors, words_span_end, 0.5 * self._half, seen, limit, base,
            join)
        pending = self._open_burst.pop(bus, None)
        if pending is not None:
            p_start, p_active, p_end = pending
            if b_start.size and b_start[0] <= p_end + join:
                b_start[0], active[0] = p_start, active[0] + p_active
            else:
                b_start = np.r_[p_start, b_start]
                b_end = np.r_[p_end, b_end]
                active = np.r_[p_active, active]
        if b_start.size == 0:
            return empty_words()
        done = b_end + join < limit + base
        if not done[-1]:
            self._open_burst[bus] = (float(b_start[-1]), float(active[-1]), float(b_end[-1]))
        if not np.any(done):
            return empty_words()
        self._last_burst[bus] = max(self._last_burst[bus], float(b_end[done].max()))
        keep = done & (active >= self.settings.burst_min_us * self._spus)
        out = empty_words(int(keep.sum()))
        out["t_ns"] = np.rint(b_start[keep] * 1e9 / self.sample_rate)
        out["end_ns"] = np.rint(b_end[keep] * 1e9 / self.sample_rate)
        out["errors"] = ERR_SYNC
        out["sync"] = SYNC_DATA
        out["bus"] = bus
        return out


def _in_time_order(words: WordBatch) -> WordBatch:
    """The words sorted by time, bus A first at equal times (so that the order does not
    depend on which call returned which); most batches already are, and are not copied."""
    key = words["t_ns"] * 2 + words["bus"]
    if key.size < 2 or bool((key[1:] >= key[:-1]).all()):
        return words
    return take_words(words, np.argsort(key, kind="stable"))


def decode_capture(samples: npt.NDArray[np.uint8], sample_rate: float,
                   settings: DecoderSettings | None = None) -> WordBatch:
    """Decode a whole capture in memory."""
    return ManchesterDecoder(sample_rate, settings).decode_all(samples)
