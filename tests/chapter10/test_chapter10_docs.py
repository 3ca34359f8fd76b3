"""docs/chapter10.md stays true: its block status table and its ARINC 429 line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from drivers.chapter10.arinc429 import Arinc429Words, split_words
from drivers.chapter10.status import ERROR_BITS, MESSAGE_ERROR, block_status_for, errors_for
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, MonitorRecord, TransferFormat

PAGE = Path(__file__).resolve().parents[2] / "docs" / "chapter10.md"


def table_rows() -> dict[int, tuple[str, str]]:
    """bit -> (read as, written for) from the page's block status table."""
    rows = {}
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[0].isdigit():
            rows[int(cells[0])] = (cells[2], cells[3])
    return rows


def names(cell: str) -> set[str]:
    return {n for n in re.findall(r"`([a-z_]+)`", cell) if n in MESSAGE_ERROR_NAMES}


def test_the_written_for_column_is_the_code() -> None:
    rows = table_rows()
    assert sorted(rows) == [3, 4, 5, 9, 10, 11, 12, 13]
    for bit, (_, written) in rows.items():
        if bit in (11, 12, 13):
            continue
        assert names(written) == {n for n, b in ERROR_BITS.items() if b == 1 << bit}, bit
    excepted = names(rows[12][1])  # "any error except ..."
    assert excepted == {"time_tags_unavailable"}
    for name in MESSAGE_ERROR_NAMES:
        record = MonitorRecord(0, "A", TransferFormat.BC_RT, 0x0822, errors=(name,))
        assert bool(block_status_for(record) & MESSAGE_ERROR) == (name not in excepted), name


def test_the_read_as_column_is_the_code() -> None:
    for bit, (read, _) in table_rows().items():
        if bit in (11, 12, 13):
            continue
        assert set(errors_for(1 << bit)) <= names(read), bit


def test_the_arinc429_example_line_is_what_decode_prints() -> None:
    text = PAGE.read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"```json\n(.*?)```", text, re.S) if "arinc429" in b)
    shown = json.loads(block)
    word = np.array([int(shown["word"], 16)], dtype=np.uint32)
    fields = split_words(word)
    words = Arinc429Words(
        channel=shown["channel"], t_ns=np.array([shown["t_ns"]]),
        bus=np.array([shown["bus"]], dtype=np.uint8), high_speed=np.array([True]), word=word,
        label=fields["label"], sdi=fields["sdi"], data=fields["data"], ssm=fields["ssm"],
        parity_ok=fields["parity_ok"], parity_error=np.array([False]),
        format_error=np.array([False]))
    assert words.to_json() == [shown]
