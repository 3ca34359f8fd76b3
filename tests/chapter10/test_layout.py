"""Stored words split into command, status and data by the transfer format."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drivers.chapter10.layout import split_message
from drivers.mil1553.record import TransferFormat as F


def cmd(rt: int, tr: str, sa: int, count: int) -> int:
    return rt << 11 | (tr == "T") << 10 | sa << 5 | count


def status(rt: int, bits: int = 0) -> int:
    return rt << 11 | bits


D1, D2, D3 = 0x1111, 0x2222, 0x3333


@pytest.mark.parametrize(("words", "rt_rt", "fmt", "data", "stat"), [
    ((cmd(5, "R", 1, 2), D1, D2, status(5)), False, F.BC_RT, (D1, D2), (status(5),)),
    ((cmd(5, "T", 1, 2), status(5), D1, D2), False, F.RT_BC, (D1, D2), (status(5),)),
    ((cmd(6, "R", 3, 2), cmd(2, "T", 4, 2), status(2), D1, D2, status(6)), True, F.RT_RT,
     (D1, D2), (status(2), status(6))),
    ((cmd(31, "R", 3, 2), cmd(2, "T", 4, 2), status(2), D1, D2), True, F.BCAST_RT_RT,
     (D1, D2), (status(2),)),
    ((cmd(5, "T", 0, 2), status(5)), False, F.MODE, (), (status(5),)),
    ((cmd(5, "T", 31, 19), status(5), D1), False, F.MODE_TX_DATA, (D1,), (status(5),)),
    ((cmd(5, "R", 0, 17), D1, status(5)), False, F.MODE_RX_DATA, (D1,), (status(5),)),
    ((cmd(31, "T", 0, 1),), False, F.BCAST_MODE, (), ()),
    ((cmd(31, "R", 0, 17), D1), False, F.BCAST_MODE_RX_DATA, (D1,), ()),
    ((cmd(31, "R", 9, 3), D1, D2, D3), False, F.BCAST_BC_RT, (D1, D2, D3), ()),
])
def test_each_transfer_format_splits_as_on_the_bus(words: tuple[int, ...], rt_rt: bool,
                                                    fmt: F, data: tuple[int, ...],
                                                    stat: tuple[int, ...]) -> None:
    split = split_message(words, rt_to_rt=rt_rt, timed_out=False)
    assert (split.format, split.data, split.status) == (fmt, data, stat)
    assert split.command == words[0]
    assert split.command2 == (words[1] if rt_rt else None)
    assert split.expected_words == len(words)
    assert split.errors == frozenset()


def test_thirty_two_words_for_a_count_of_zero() -> None:
    words = (cmd(4, "T", 2, 0), status(4), *range(32))
    split = split_message(words, rt_to_rt=False, timed_out=False)
    assert split.data == tuple(range(32)) and split.expected_words == 34


def test_no_response_holds_only_what_was_on_the_bus() -> None:
    transmit = split_message((cmd(26, "T", 29, 1),), rt_to_rt=False, timed_out=True)
    assert (transmit.format, transmit.data, transmit.status) == (F.RT_BC, (), ())
    assert transmit.expected_words == 1
    receive = split_message((cmd(8, "R", 1, 2), D1, D2), rt_to_rt=False, timed_out=True)
    assert (receive.format, receive.data, receive.status) == (F.BC_RT, (D1, D2), ())
    assert receive.expected_words == 3
    # RT-RT: the transmitter silent (both commands only) or the receiver silent
    tx_silent = split_message((cmd(6, "R", 3, 2), cmd(2, "T", 4, 2)), rt_to_rt=True,
                              timed_out=True)
    assert (tx_silent.data, tx_silent.status, tx_silent.expected_words) == ((), (), 2)
    rx_silent = split_message((cmd(6, "R", 3, 2), cmd(2, "T", 4, 2), status(2), D1, D2),
                              rt_to_rt=True, timed_out=True)
    assert (rx_silent.data, rx_silent.status, rx_silent.expected_words) == \
        ((D1, D2), (status(2),), 5)


def test_too_few_and_too_many_words() -> None:
    short = split_message((cmd(5, "T", 1, 3), status(5), D1), rt_to_rt=False, timed_out=False)
    assert (short.data, short.status, short.expected_words) == ((D1,), (status(5),), 5)
    # the BC sent one word too many and the terminal still answered: last word is status
    long = split_message((cmd(5, "R", 1, 1), D1, D2, status(5)), rt_to_rt=False,
                         timed_out=False)
    assert (long.data, long.status, long.expected_words) == ((D1, D2), (status(5),), 3)
    # ... or timed out: every extra word is data
    silent = split_message((cmd(5, "R", 1, 1), D1, D2), rt_to_rt=False, timed_out=True)
    assert (silent.data, silent.status, silent.expected_words) == ((D1, D2), (), 2)


def test_errors_the_words_and_gaps_show_are_found_again() -> None:
    wrong_rt = split_message((cmd(5, "T", 1, 1), status(6), D1), rt_to_rt=False,
                             timed_out=False)
    assert wrong_rt.errors == {"wrong_rt_address"}
    reserved = split_message((cmd(5, "T", 1, 1), status(5, 0x0020), D1), rt_to_rt=False,
                             timed_out=False)
    assert reserved.errors == {"reserved_status_bits"}
    late = split_message((cmd(5, "T", 1, 1), status(5), D1), rt_to_rt=False, timed_out=False,
                         gaps_ns=(12_500, 0))
    early = split_message((cmd(5, "T", 1, 1), status(5), D1), rt_to_rt=False, timed_out=False,
                          gaps_ns=(3_000, 0))
    in_time = split_message((cmd(5, "T", 1, 1), status(5), D1), rt_to_rt=False,
                            timed_out=False, gaps_ns=(7_000, 0))
    unmeasured = split_message((cmd(5, "T", 1, 1), status(5), D1), rt_to_rt=False,
                               timed_out=False, gaps_ns=(0, 0))
    assert (late.errors, early.errors) == ({"late_response"}, {"early_response"})
    assert in_time.errors == unmeasured.errors == frozenset()
    bcast_tx = split_message((cmd(31, "T", 1, 1),), rt_to_rt=False, timed_out=False)
    assert bcast_tx.errors == {"illegal_format"}
    reserved_mode = split_message((cmd(5, "T", 0, 12), status(5)), rt_to_rt=False,
                                  timed_out=False)
    assert reserved_mode.errors == {"reserved_mode_code"}
    rt_rt_same = split_message((cmd(6, "R", 3, 1), cmd(6, "T", 4, 1), status(6), D1,
                                status(6)), rt_to_rt=True, timed_out=False)
    assert rt_rt_same.errors == {"illegal_format"}


def on_the_bus(command: int, command2: int | None, payload: list[int]
               ) -> tuple[list[int], int, int, list[int]]:
    """A complete message built from the standard's formats, independently of the layout
    code: (words in bus order, index of the first data word, data words, status indices)."""
    from drivers.mil1553.modecodes import MODE_CODES
    rt, tx, sa, count = command >> 11, command >> 10 & 1, command >> 5 & 31, command & 31
    if command2 is not None:
        rt2, n = command2 >> 11, (command2 & 31) or 32
        words = [command, command2, status(rt2), *payload[:n]]
        if rt == 31:
            return words, 3, n, [2]
        return [*words, status(rt)], 3, n, [2, 3 + n]
    if sa in (0, 31):
        n = 1 if MODE_CODES[count].has_data else 0
        if rt == 31:
            n = 0 if tx else n
            return [command, *payload[:n]], 1, n, []
        if tx:
            return [command, status(rt), *payload[:n]], 2, n, [1]
        return [command, *payload[:n], status(rt)], 1, n, [1 + n]
    n = count or 32
    if rt == 31:
        n = 0 if tx else n
        return [command, *payload[:n]], 1, n, []
    if tx:
        return [command, status(rt), *payload[:n]], 2, n, [1]
    return [command, *payload[:n], status(rt)], 1, n, [1 + n]


@given(rt=st.integers(0, 31), tx=st.booleans(), sa=st.integers(0, 31), count=st.integers(0, 31),
       rt_rt=st.booleans(), rt2=st.integers(0, 30), sa2=st.integers(1, 30),
       payload=st.lists(st.integers(0, 0xFFFF), min_size=32, max_size=32))
def test_any_complete_message_splits_back_into_its_parts(rt: int, tx: bool, sa: int,
                                                         count: int, rt_rt: bool, rt2: int,
                                                         sa2: int, payload: list[int]) -> None:
    command = cmd(rt, "T" if tx else "R", sa, count)
    rt_rt = rt_rt and not tx and sa not in (0, 31) and rt2 != rt
    command2 = cmd(rt2, "T", sa2, count) if rt_rt else None
    words, first, n, status_at = on_the_bus(command, command2, payload)
    split = split_message(tuple(words), rt_to_rt=rt_rt, timed_out=False)
    assert split.data == tuple(words[first:first + n])
    assert split.status == tuple(words[i] for i in status_at)
    assert (split.command, split.command2, split.expected_words) == \
        (command, command2, len(words))
    assert "wrong_rt_address" not in split.errors
    if status_at:
        # the last terminal silent: only the words before its status were on the bus
        kept = tuple(words[:status_at[-1]])
        silent = split_message(kept, rt_to_rt=rt_rt, timed_out=True)
        assert silent.status == tuple(words[i] for i in status_at[:-1])
        assert silent.data == tuple(words[first:min(first + n, len(kept))])
        assert silent.expected_words == len(kept)
