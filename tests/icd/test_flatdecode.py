"""The one-pass decoder of a whole batch (every message of the table at once) gives each
cell the value, raw code and flags the per-message decoder gives, bit for bit."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from mapr_daemon.icd import Icd, load_icd
from mapr_daemon.icd.flatdecode import NO_LABEL, decode_cells, flatten

from .conftest import EMA_TABLE, REPO

SEED = 20261126
TWO_EMA = REPO / "configs" / "icd" / "ema-testbed-two-ema.yaml"
ONE_PARAMETER_SPECS = [
    "type: twos, bits: [13, 2], lsb: 0.25, offset: -3.0",
    "type: bnr, bits: [15, 0], msb_weight: 90.0, minimum: -10, maximum: 10",
    "type: unsigned, words: 2, word_order: lsw_first, lsb: 0.001",
    "type: twos, words: 2, bits: [27, 4], lsb: 1.0e-5, word_order: lsw_first",
    "type: float32, minimum: -1, maximum: 1",
    "type: float32, word_order: lsw_first, lsb: 0.5",
    "type: bcd, bits: [15, 0], lsb: 0.1",
    "type: bcd, bits: [11, 0], offset: 7, maximum: 50",
    "type: enum, bits: [3, 0], values: {0: idle, 1: run, 5: fault}",
    "type: discrete, bits: [9, 9]",
    "type: counter, bits: [7, 0]",
]


def check_against_message_decoder(icd: Icd, records: int, seed: int) -> int:
    """Decode ``records`` random records of each message (short, whole and long, some
    with bus errors, some without data words) both ways; return the cells compared."""
    rng = np.random.default_rng(seed)
    table = flatten(icd.messages)
    message = np.repeat(np.arange(len(icd.messages)), records)
    word_count = np.array([m.word_count for m in icd.messages])[message]
    count = np.clip(word_count + rng.choice([-2, -1, 0, 0, 0, 1], message.size), 0, None)
    count[rng.random(message.size) < 0.05] = 0
    start = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    words = rng.integers(0, 1 << 16, int(count.sum()) + 1, dtype=np.int64).astype(np.uint16)
    error = (rng.random(message.size) < 0.1).astype(np.uint8)
    row_cell = np.zeros(message.size + 1, np.int64)
    np.cumsum(np.where(count > 0, table.cells_per_message[message], 0), out=row_cell[1:])
    value, raw, flags, label = decode_cells(table, words, start, count.astype(np.int64),
                                            error, message.astype(np.int64), row_cell)
    compared = 0
    for k, m in enumerate(icd.messages):
        rows = np.flatnonzero((message == k) & (count > 0))
        wc = m.word_count
        length = np.minimum(count[rows], wc)
        data = np.zeros((rows.size, wc), np.uint16)
        for j, r in enumerate(rows.tolist()):
            data[j, :length[j]] = words[start[r]:start[r] + length[j]]
        series = icd.decode_block(m.name, data, length.astype(np.intp),
                                  np.zeros(rows.size, np.int64), error[rows] != 0)
        field = table.field_start[k]
        cells = np.concatenate([np.arange(row_cell[r], row_cell[r + 1]) for r in rows]) \
            if rows.size else np.zeros(0, np.int64)
        offset = 0
        for name, s in series.items():
            assert table.fields[field].name == name
            width = len(s) // max(rows.size, 1)
            mine = cells.reshape(rows.size, -1)[:, offset:offset + width].ravel()
            assert np.array_equal(value[mine].view(np.int64), s.value.view(np.int64)) or \
                np.array_equal(value[mine], s.value, equal_nan=True), name
            assert np.array_equal(raw[mine], s.raw), name
            assert np.array_equal(flags[mine], s.flags), name
            texts = [table.labels[i] if i != NO_LABEL else None for i in label[mine].tolist()]
            assert texts == [s.parameter.label(c) or None for c in s.raw.tolist()], name
            compared += mine.size
            offset += width
            field += 1
    return compared


@pytest.mark.parametrize("path", [EMA_TABLE, TWO_EMA], ids=["ema", "two-ema"])
def test_every_message_of_the_tables_decodes_as_the_message_decoder_does(path: object
                                                                         ) -> None:
    icd = load_icd(str(path))
    assert check_against_message_decoder(icd, 60, SEED) > 5000


@pytest.mark.parametrize("spec", ONE_PARAMETER_SPECS)
def test_each_kind_of_parameter_decodes_as_the_message_decoder_does(
        one_parameter: Callable[..., Icd], spec: str) -> None:
    icd = one_parameter(spec)
    assert check_against_message_decoder(icd, 400, SEED + 1) > 300


def test_a_record_without_data_words_gets_no_cells() -> None:
    icd = load_icd(str(EMA_TABLE))
    table = flatten(icd.messages)
    row_cell = np.array([0, 0, int(table.cells_per_message[0])], np.int64)
    words = np.arange(64, dtype=np.uint16)
    value, _, flags, _ = decode_cells(table, words, np.zeros(2, np.int64),
                                      np.array([0, 40], np.int64), np.zeros(2, np.uint8),
                                      np.zeros(2, np.int64), row_cell)
    assert value.size == flags.size == table.cells_per_message[0]
