"""ARINC 429 words from Chapter 10 packets: field split, parity, times, the sample's figures."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from drivers.chapter10.arinc429 import split_words
from drivers.chapter10.reader import Chapter10Reader


def test_the_reference_vectors_split_into_their_fields() -> None:
    fields = split_words(np.array([0xE01F4050, 0xE00190A1], dtype=np.uint32))
    assert fields["label"].tolist() == [0o012, 0o205]
    assert fields["sdi"].tolist() == [0, 0]
    assert fields["data"].tolist() == [2000, 100]
    assert fields["ssm"].tolist() == [3, 3]
    assert fields["parity_ok"].tolist() == [True, True]


def test_every_single_bit_flip_breaks_the_parity() -> None:
    flipped = np.uint32(0xE01F4050) ^ (np.uint32(1) << np.arange(32, dtype=np.uint32))
    assert not split_words(flipped)["parity_ok"].any()


def test_a_packet_decodes_with_times_bus_and_flags(c10: Any, tmp_path: Path) -> None:
    path = tmp_path / "a429.c10"
    path.write_bytes(c10.arinc429([0xE01F4050, 0xE01F4051, 0xE00190A1], rtc=0,
                                  gaps=[0, 3620, 400_000], bus=3))
    (batch,) = list(Chapter10Reader(path))
    words = batch.arinc429
    assert words is not None and batch.records == []
    rows = words.to_json()
    assert [r["t_ns"] for r in rows] == [0, 362_000, 40_362_000]
    assert [r["label"] for r in rows] == ["012", "212", "205"]
    assert [r["errors"] for r in rows] == [[], ["parity"], []]
    assert rows[0] == {"t_ns": 0, "kind": "arinc429", "channel": 9, "bus": 3, "speed": "high",
                       "label": "012", "sdi": 0, "data": 2000, "ssm": 3,
                       "word": "0xE01F4050", "errors": []}


def test_the_recorders_parity_flag_is_kept(c10: Any, tmp_path: Path) -> None:
    path = tmp_path / "pe.c10"
    path.write_bytes(c10.arinc429([0xE01F4050], rtc=0, gaps=[0], parity_error=True))
    (batch,) = list(Chapter10Reader(path))
    assert batch.arinc429 is not None and batch.arinc429.to_json()[0]["errors"] == ["parity"]


def test_the_sample_holds_4861_words_all_with_good_parity(sample_c10: Path) -> None:
    batches = [b.arinc429 for b in Chapter10Reader(sample_c10) if b.arinc429 is not None]
    assert len(batches) == 18
    assert sum(len(w) for w in batches) == 4861
    assert sum(int((~w.parity_ok).sum()) for w in batches) == 0
    assert sum(int(w.parity_error.sum()) for w in batches) == 0
    assert {w.channel for w in batches} == {6, 7, 8, 9, 10, 11}
    for w in batches:
        assert (np.diff(w.t_ns) >= 0).all()  # gaps accumulate forward
