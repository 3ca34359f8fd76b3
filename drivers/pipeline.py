"""Samples to messages: the Manchester decoder and the message assembler, chained.

Every bit-level source (capture files, the USB logic-analyzer card, the loopback bus at bit
level) goes through this one chain, so they all decode alike.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.decoder import DecoderSettings, ManchesterDecoder
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.mil1553.wordbatch import WordBatch


class SamplePipeline:
    """Feed capture samples, get :class:`MonitorRecord` messages (and, if wanted, words)."""

    def __init__(self, sample_rate: float, *, timing: BusTiming | None = None,
                 settings: DecoderSettings | None = None) -> None:
        self.decoder = ManchesterDecoder(sample_rate, settings)
        self.assembler = MessageAssembler(timing)
        self.last_words: WordBatch = np.zeros(0, dtype=self.decoder.flush().dtype)

    @property
    def sample_rate(self) -> float:
        return self.decoder.sample_rate

    def feed(self, samples: npt.NDArray[np.uint8]) -> list[MonitorRecord]:
        """Decode a chunk; return the messages completed so far."""
        words = self.decoder.feed(samples)
        self.last_words = words
        horizon = self.decoder.complete_until_ns
        return self.assembler.feed(words, horizon_ns=None if math.isinf(horizon) else
                                   int(horizon))

    def flush(self) -> list[MonitorRecord]:
        """End of the samples: every open word and message is finished."""
        words = self.decoder.flush()
        self.last_words = words
        return self.assembler.feed(words) + self.assembler.flush()
