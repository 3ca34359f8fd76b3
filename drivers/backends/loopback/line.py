"""From the controller's :class:`Traffic` to what a monitor receives: samples or word batches.

Bit level: the words go through :func:`~drivers.mil1553.encoder.encode_words` (with their
injected faults and any signal impairments) chunk by chunk, so the sample stream is one
continuous capture from t = 0, and noise bursts overwrite the bus's receiver outputs with
random line states (each state 100-700 ns, never the same twice in a row, so no burst can
pass for a sync).

Word level: each word becomes the row a decoder would give for it (a faulted word flagged
with its error class, an inverted sync read as the other sync type, a noise burst as one
``sync``-flagged word), straight into the message assembler.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from drivers.backends.loopback.controller import Burst, BusWord, Traffic
from drivers.mil1553.encoder import RX_BITS, Impairments, WordFault, encode_words
from drivers.mil1553.wordbatch import (
    ERR_BIT_COUNT_HIGH,
    ERR_BIT_COUNT_LOW,
    ERR_MANCHESTER,
    ERR_PARITY,
    ERR_SYNC,
    SYNC_DATA,
    WordBatch,
    empty_words,
)


def word_errors(fault: WordFault) -> int:
    """The error bits a decoder reports for a word sent with ``fault``."""
    bits = 0
    if fault.parity:
        bits |= ERR_PARITY
    if fault.no_transition is not None:
        bits |= ERR_MANCHESTER
    if fault.bit_count < 0:
        bits |= ERR_BIT_COUNT_LOW
    elif fault.bit_count > 0:
        bits |= ERR_BIT_COUNT_HIGH
    return bits


def traffic_words(traffic: Traffic) -> WordBatch:
    """The word batch a perfect decoder would give for ``traffic`` (the fast path)."""
    rows = empty_words(len(traffic.words) + len(traffic.bursts))
    for i, w in enumerate(traffic.words):
        rows[i] = (w.t_ns, w.bus, w.sync ^ int(w.fault.inverted_sync), w.value,
                   word_errors(w.fault), w.end_ns)
    for j, b in enumerate(traffic.bursts, start=len(traffic.words)):
        rows[j] = (b.t_ns, b.bus, SYNC_DATA, 0, ERR_SYNC, b.end_ns)
    out: WordBatch = rows[np.argsort(rows["t_ns"], kind="stable")]
    return out


class SampleWriter:
    """Turns successive :class:`Traffic` frames into one continuous sample stream."""

    def __init__(self, sample_rate: float, impairments: Impairments | None = None,
                 seed: int = 0) -> None:
        self.sample_rate = float(sample_rate)
        self._rng = np.random.default_rng(seed)
        self.impairments = dataclasses.replace(impairments or Impairments(), rng=self._rng)
        self.samples_written = 0

    def _sample_at(self, t_ns: int) -> int:
        return int(np.floor(t_ns * self.sample_rate / 1e9))

    def write(self, traffic: Traffic) -> npt.NDArray[np.uint8]:
        """The samples from where the last call ended to ``traffic.end_ns``."""
        first = self.samples_written
        last = max(first, self._sample_at(traffic.end_ns))
        offset_ns = first * 1e9 / self.sample_rate
        words = _word_rows(traffic.words, offset_ns)
        duration = (last - first) * 1e9 / self.sample_rate
        samples = encode_words(words, self.sample_rate, impairments=self.impairments,
                               faults=[w.fault for w in traffic.words], duration_ns=int(duration))
        out = np.zeros(last - first, dtype=np.uint8)
        n = min(out.size, samples.size)
        out[:n] = samples[:n]
        for burst in traffic.bursts:
            self._noise(out, burst, offset_ns)
        self.samples_written = last
        return out

    def _noise(self, out: npt.NDArray[np.uint8], burst: Burst, offset_ns: float) -> None:
        rng = np.random.default_rng(burst.seed)
        pos_bit, neg_bit = RX_BITS[burst.bus]
        mask = np.uint8(pos_bit | neg_bit)
        t = burst.t_ns - offset_ns
        state = 0
        while t < burst.end_ns - offset_ns:
            length = float(rng.uniform(100.0, 700.0))
            state = (state + int(rng.integers(1, 3))) % 3  # 0 idle, 1 positive, 2 negative
            a = max(0, int(np.ceil(t * self.sample_rate / 1e9)))
            b = min(out.size, int(np.ceil((t + length) * self.sample_rate / 1e9)))
            level = (0, pos_bit, neg_bit)[state]
            out[a:b] = (out[a:b] & ~mask) | np.uint8(level)
            t += length


def _word_rows(words: list[BusWord], offset_ns: float) -> WordBatch:
    rows = empty_words(len(words))
    if words:
        rows["t_ns"] = np.rint(np.array([w.t_ns for w in words], dtype=np.float64) - offset_ns)
        rows["bus"] = [w.bus for w in words]
        rows["sync"] = [w.sync for w in words]
        rows["value"] = [w.value for w in words]
    return rows
