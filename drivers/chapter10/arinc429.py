"""ARINC 429 packets (data type 0x38) to words, split into their fields with numpy.

A Chapter 10 ARINC 429 Format 0 packet holds, after its channel-specific word (word count),
8 bytes per bus word: a 32-bit intra-packet header (bits 0-19 gap time in 0.1 µs from the
previous word on any bus, or from the packet time for the first; 21 bus speed; 22 parity
error; 23 format error; 24-31 bus number) and the 32-bit word as received.

The word's fields (ARINC 429 bit numbers 1-32 are bits 0-31 of the stored word): the label,
bits 1-8, is sent most significant bit first and so stored bit-reversed in the low byte;
SDI bits 9-10; data bits 11-29; SSM bits 30-31; bit 32 makes the word's parity odd.
Example: 0xE01F4050 is label 012, SDI 0, data 2000, SSM 3, parity good. Labels are
written as engineers write them: three octal digits without a prefix (``271``, not ``0o271``).

Every step is one numpy operation over all the words of a packet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from drivers.chapter10.timebase import RTC_NS

ENTRY_DTYPE = np.dtype([("header", "<u4"), ("word", "<u4")])

_REVERSED = np.array([int(f"{b:08b}"[::-1], 2) for b in range(256)], dtype=np.uint8)
_POPCOUNT = np.array([bin(b).count("1") for b in range(256)], dtype=np.uint32)


@dataclass(frozen=True, slots=True)
class Arinc429Words:
    """The words of one packet, field by field (arrays of equal length)."""

    channel: int
    t_ns: npt.NDArray[np.int64]
    bus: npt.NDArray[np.uint8]
    high_speed: npt.NDArray[np.bool_]
    word: npt.NDArray[np.uint32]
    label: npt.NDArray[np.uint8]
    sdi: npt.NDArray[np.uint8]
    data: npt.NDArray[np.uint32]
    ssm: npt.NDArray[np.uint8]
    parity_ok: npt.NDArray[np.bool_]
    """The word's own odd parity holds."""
    parity_error: npt.NDArray[np.bool_]
    """The recorder flagged a parity error."""
    format_error: npt.NDArray[np.bool_]
    """The recorder flagged a format error."""

    def __len__(self) -> int:
        return int(self.word.size)

    def to_json(self) -> list[dict[str, Any]]:
        """One JSON object per word, as ``mapr decode`` prints them."""
        rows = []
        for i in range(len(self)):
            errors = []
            if not self.parity_ok[i] or self.parity_error[i]:
                errors.append("parity")
            if self.format_error[i]:
                errors.append("format")
            rows.append({
                "t_ns": int(self.t_ns[i]), "kind": "arinc429", "channel": self.channel,
                "bus": int(self.bus[i]), "speed": "high" if self.high_speed[i] else "low",
                "label": label_text(int(self.label[i])), "sdi": int(self.sdi[i]),
                "data": int(self.data[i]), "ssm": int(self.ssm[i]),
                "word": f"0x{int(self.word[i]):08X}", "errors": errors})
        return rows


def label_text(label: int) -> str:
    """A label as ARINC 429 documents write it: three octal digits, no prefix (``"271"``).

    >>> label_text(0o271), label_text(0o12)
    ('271', '012')
    """
    return f"{int(label):03o}"


def split_words(words: npt.NDArray[np.uint32]) -> dict[str, npt.NDArray[Any]]:
    """Label (octal digits as an integer), SDI, data, SSM and parity check of raw words.

    >>> f = split_words(np.array([0xE01F4050, 0xE00190A1], dtype=np.uint32))
    >>> [label_text(x) for x in f["label"]], f["data"].tolist(), f["ssm"].tolist()
    (['012', '205'], [2000, 100], [3, 3])
    """
    w = words.astype(np.uint32)
    ones = sum((_POPCOUNT[(w >> shift) & 0xFF] for shift in range(0, 32, 8)),
               start=np.zeros(w.shape, dtype=np.uint32))
    return {
        "label": _REVERSED[w & 0xFF],
        "sdi": ((w >> 8) & 0x3).astype(np.uint8),
        "data": (w >> 10) & 0x7FFFF,
        "ssm": ((w >> 29) & 0x3).astype(np.uint8),
        "parity_ok": (ones & 1) == 1,
    }



def words_from_packet(body: bytes, count: int, channel: int, packet_ns: int
                      ) -> Arinc429Words:
    """The words of one packet: ``body`` the bytes after the channel-specific word,
    ``count`` the words it announces (fewer if the body is shorter), ``packet_ns`` the
    packet's time."""
    usable = min(count, len(body) // ENTRY_DTYPE.itemsize)
    entries = np.frombuffer(body, dtype=ENTRY_DTYPE, count=usable)
    header = entries["header"]
    gaps = (header & 0xFFFFF).astype(np.int64) * RTC_NS
    fields = split_words(entries["word"])
    return Arinc429Words(
        channel=channel, t_ns=packet_ns + np.cumsum(gaps),
        bus=(header >> 24).astype(np.uint8), high_speed=(header >> 21 & 1) == 1,
        word=entries["word"].astype(np.uint32), label=fields["label"], sdi=fields["sdi"],
        data=fields["data"], ssm=fields["ssm"], parity_ok=fields["parity_ok"],
        parity_error=(header >> 22 & 1) == 1, format_error=(header >> 23 & 1) == 1)
