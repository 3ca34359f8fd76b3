"""The MS1553F1 block status word, both ways (IRIG 106 Chapter 10 bit positions)."""

from __future__ import annotations

import pytest

from drivers.chapter10.status import (
    block_status_for,
    errors_for,
    errors_for_words,
    is_bus_b,
    is_rt_to_rt,
)
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, MonitorRecord, TransferFormat

ME, RR, FE, TM, LE, SE, WE, BID = 1 << 12, 1 << 11, 1 << 10, 1 << 9, 1 << 5, 1 << 4, 1 << 3, 1 << 13


def _record(bus: str = "A", fmt: TransferFormat = TransferFormat.BC_RT,
            errors: tuple[str, ...] = ()) -> MonitorRecord:
    return MonitorRecord(t_ns=0, bus=bus, format=fmt, command=0x0822, errors=errors)


@pytest.mark.parametrize(("errors", "expected"), [
    ((), 0),
    (("no_response",), ME | TM),
    (("word_count_low",), ME | LE),
    (("word_count_high",), ME | LE),
    (("sync",), ME | SE),
    (("word_error", "parity"), ME | WE),
    (("manchester",), ME | WE),
    (("bit_count_low",), ME | WE),
    (("bit_count_high",), ME | WE),
    (("illegal_format",), ME | FE),
    (("reserved_mode_code",), ME | FE),
    (("non_contiguous_data",), ME | FE),
    (("superseded", "word_count_low"), ME | FE | LE),
    (("orphan_words",), ME | FE),
    (("babbling",), ME | FE),
    (("late_response",), ME),
    (("early_response",), ME),
    (("wrong_rt_address",), ME),
    (("reserved_status_bits",), ME),
    (("intermessage_gap_short",), ME),
    (("both_buses_active",), ME),
    (("time_tags_unavailable",), 0),
    (("no_response", "sync", "word_error"), ME | TM | SE | WE),
])
def test_error_names_set_the_documented_bits(errors: tuple[str, ...], expected: int) -> None:
    assert block_status_for(_record(errors=errors)) == expected


def test_every_error_name_sets_message_error_except_the_monitors_own() -> None:
    for name in MESSAGE_ERROR_NAMES:
        word = block_status_for(_record(errors=(name,)))
        assert bool(word & ME) == (name != "time_tags_unavailable"), name


def test_bus_and_rt_to_rt_bits() -> None:
    assert block_status_for(_record(bus="B")) == BID
    assert block_status_for(_record(fmt=TransferFormat.RT_RT)) == RR
    assert block_status_for(_record(bus="B", fmt=TransferFormat.BCAST_RT_RT)) == BID | RR
    assert block_status_for(_record(fmt=TransferFormat.MODE_TX_DATA)) == 0
    assert is_bus_b(BID) and not is_bus_b(0x1FFF)
    assert is_rt_to_rt(RR) and not is_rt_to_rt(0xFFFF & ~RR)


@pytest.mark.parametrize(("word", "names"), [
    (0, ()),
    (BID | RR, ()),
    (ME, ()),
    (ME | TM, ("no_response",)),
    (BID | ME | TM, ("no_response",)),
    (ME | LE, ("word_count_low",)),
    (ME | SE, ("sync",)),
    (ME | WE, ("word_error",)),
    (ME | FE, ("illegal_format",)),
    (ME | FE | TM | LE | SE | WE,
     ("illegal_format", "no_response", "sync", "word_count_low", "word_error")),
])
def test_flags_read_as_our_names(word: int, names: tuple[str, ...]) -> None:
    assert errors_for(word) == names
    assert set(names) <= set(MESSAGE_ERROR_NAMES)


def test_word_count_error_is_high_or_low_by_the_words_stored() -> None:
    assert errors_for_words(ME | LE, expected_words=5, stored_words=3) == ("word_count_low",)
    assert errors_for_words(ME | LE, expected_words=5, stored_words=7) == ("word_count_high",)
    assert errors_for_words(ME | LE | TM, expected_words=5, stored_words=6) == \
        ("no_response", "word_count_high")
    # without LE the counts change nothing
    assert errors_for_words(ME | TM, expected_words=5, stored_words=1) == ("no_response",)


@pytest.mark.parametrize("errors", [
    ("no_response",), ("word_count_low",), ("sync",), ("word_error",), ("illegal_format",),
    ("no_response", "sync", "word_count_low"),
])
def test_the_names_each_bit_reads_back_as_round_trip(errors: tuple[str, ...]) -> None:
    assert errors_for(block_status_for(_record(errors=errors))) == tuple(sorted(errors))
