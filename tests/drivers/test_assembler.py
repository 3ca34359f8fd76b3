"""Message assembler: every transfer format, every error class, streaming equivalence."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.mil1553.assembler import MessageAssembler, assemble
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.wordbatch import ERR_PARITY, empty_words
from drivers.mil1553.words import CommandWord, StatusWord

CMD, DATA = 1, 0


class Bus:
    """Writes words as a bus would carry them; gaps are idle time between words (µs)."""

    def __init__(self) -> None:
        self.rows: list[tuple[int, int, int, int, int]] = []
        self.t = 1_000

    def word(self, sync: int, value: int, idle_us: float = 0, bus: int = 0,
             errors: int = 0) -> Bus:
        self.t += int(idle_us * 1000)
        self.rows.append((self.t, bus, sync, value, errors))
        self.t += 20_000
        return self

    def cmd(self, rt: int, tx: bool, sa: int, count: int, idle_us: float = 10,
            bus: int = 0) -> Bus:
        return self.word(CMD, CommandWord(rt, tx, sa, count).value, idle_us, bus)

    def status(self, rt: int, idle_us: float = 6, bus: int = 0, **flags: bool) -> Bus:
        return self.word(CMD, StatusWord(rt, **flags).value, idle_us, bus)

    def data(self, *values: int, bus: int = 0) -> Bus:
        for v in values:
            self.word(DATA, v, bus=bus)
        return self

    def words(self) -> np.ndarray:
        out = empty_words(len(self.rows))
        arr = np.array(self.rows, dtype=np.int64)
        for i, name in enumerate(("t_ns", "bus", "sync", "value", "errors")):
            out[name] = arr[:, i]
        out["end_ns"] = out["t_ns"] + 19_500
        return out


def one(bus: Bus) -> MonitorRecord:
    records = assemble(bus.words())
    assert len(records) == 1, [r.to_json() for r in records]
    return records[0]


FORMATS = [
    ("BC_RT", lambda b: b.cmd(5, False, 1, 2).data(1, 2).status(5), [1, 2], 1),
    ("RT_BC", lambda b: b.cmd(5, True, 1, 2).status(5).data(3, 4), [3, 4], 1),
    ("RT_RT", lambda b: b.cmd(6, False, 3, 2).cmd(5, True, 3, 2, idle_us=0).status(5)
     .data(1, 2).status(6), [1, 2], 2),
    ("MODE", lambda b: b.cmd(5, True, 31, 2).status(5), [], 1),
    ("MODE_TX_DATA", lambda b: b.cmd(5, True, 0, 19).status(5).data(0xB17), [0xB17], 1),
    ("MODE_RX_DATA", lambda b: b.cmd(5, False, 31, 17).data(7).status(5), [7], 1),
    ("BCAST_BC_RT", lambda b: b.cmd(31, False, 1, 2).data(1, 2), [1, 2], 0),
    ("BCAST_RT_RT", lambda b: b.cmd(31, False, 3, 1).cmd(5, True, 3, 1, idle_us=0).status(5)
     .data(9), [9], 1),
    ("BCAST_MODE", lambda b: b.cmd(31, True, 31, 1), [], 0),
    ("BCAST_MODE_RX_DATA", lambda b: b.cmd(31, False, 0, 17).data(5), [5], 0),
]


@pytest.mark.parametrize(("name", "build", "data", "statuses"), FORMATS,
                         ids=[f[0] for f in FORMATS])
def test_every_transfer_format_clean(name: str, build, data: list[int], statuses: int) -> None:
    record = one(build(Bus()))
    assert str(record.format) == name
    assert list(record.data) == data
    assert len(record.status) == statuses
    assert record.errors == ()
    assert all(g == 8_000 for g in record.gaps_ns), record.gaps_ns  # 6 µs idle + 2 µs


def test_rt_rt_fields_name_both_terminals() -> None:
    record = one(Bus().cmd(6, False, 3, 2).cmd(5, True, 4, 2, idle_us=0).status(5).data(1, 2)
                 .status(6))
    assert (record.rt, record.sa, record.rt2, record.sa2) == (6, 3, 5, 4)
    assert record.to_json()["rt2"] == 5


ERRORS = [
    ("no_response", lambda b: b.cmd(5, False, 1, 1).data(1)),
    ("late_response", lambda b: b.cmd(5, False, 1, 1).data(1).status(5, idle_us=10.5)),
    ("early_response", lambda b: b.cmd(5, False, 1, 1).data(1).status(5, idle_us=1)),
    ("word_count_low", lambda b: b.cmd(5, False, 1, 3).data(1, 2).status(5)),
    ("word_count_high", lambda b: b.cmd(5, False, 1, 1).data(1, 2).status(5)),
    ("word_count_low", lambda b: b.cmd(5, True, 1, 3).status(5).data(1, 2)),
    ("word_count_high", lambda b: b.cmd(5, True, 1, 1).status(5).data(1, 2)),
    ("non_contiguous_data", lambda b: b.cmd(5, False, 1, 2).data(1).word(DATA, 2, idle_us=3)
     .status(5)),
    ("wrong_rt_address", lambda b: b.cmd(5, False, 1, 1).data(1).status(6)),
    ("reserved_status_bits", lambda b: b.cmd(5, False, 1, 1).data(1).word(CMD, 0x2800 | 0x40,
                                                                        idle_us=6)),
    ("illegal_format", lambda b: b.cmd(31, True, 1, 2)),
    ("illegal_format", lambda b: b.cmd(5, False, 31, 2).status(5)),
    ("illegal_format", lambda b: b.cmd(31, True, 31, 2)),
    ("illegal_format", lambda b: b.cmd(6, False, 3, 2).cmd(6, True, 3, 2, idle_us=0).status(6)
     .data(1, 2).status(6)),
    ("reserved_mode_code", lambda b: b.cmd(5, True, 31, 12).status(5)),
    ("babbling", lambda b: b.cmd(5, True, 1, 2).status(5).data(*range(45))),
    ("parity", lambda b: b.cmd(5, False, 1, 1).word(DATA, 1, errors=ERR_PARITY).status(5)),
    ("sync", lambda b: b.cmd(5, True, 1, 2).status(5).data(1).word(CMD, 2)),
    ("sync", lambda b: b.cmd(5, False, 1, 1).data(1).word(DATA, 0x2800, idle_us=6)),
]


@pytest.mark.parametrize(("error", "build"), ERRORS)
def test_every_error_class_is_named(error: str, build) -> None:
    record = one(build(Bus()))
    assert error in record.errors, record.to_json()


def test_a_status_after_the_time_out_is_no_response_then_a_stray_word() -> None:
    first, second = assemble(Bus().cmd(5, False, 1, 1).data(1).status(5, idle_us=13).words())
    assert first.errors == ("no_response",)
    assert second.command == StatusWord(5).value  # read as the next command word


def test_busy_transmit_status_only_is_not_an_error() -> None:
    record = one(Bus().cmd(5, True, 1, 4).status(5, busy=True))
    assert record.errors == ()
    assert record.statuses[0].busy


def test_word_errors_name_the_word() -> None:
    record = one(Bus().cmd(5, False, 1, 2).data(1).word(DATA, 2, errors=ERR_PARITY).status(5))
    assert record.word_errors == ((2, ("parity",)),)
    assert {"word_error", "parity"} <= set(record.errors)


def test_superseding_command_ends_the_message_in_progress() -> None:
    bus = Bus().cmd(5, False, 1, 4).data(1, 2).cmd(6, False, 2, 1, idle_us=0).data(9).status(6)
    first, second = assemble(bus.words())
    assert {"superseded", "word_count_low"} <= set(first.errors)
    assert (second.rt, list(second.data), second.errors) == (6, [9], ())


def test_words_that_fit_no_message_are_a_record() -> None:
    records = assemble(Bus().data(0xDEAD, 0xBEEF).cmd(5, True, 31, 2).status(5).words())
    assert str(records[0].format) == "UNKNOWN"
    assert records[0].errors == ("orphan_words",) and list(records[0].data) == [0xDEAD, 0xBEEF]
    assert records[1].errors == ()


def test_intermessage_gap_too_short() -> None:
    records = assemble(Bus().cmd(5, True, 31, 2).status(5).cmd(5, True, 31, 2, idle_us=1)
                       .status(5).words())
    assert records[1].errors == ("intermessage_gap_short",)


def test_retry_on_the_other_bus() -> None:
    bus = Bus().cmd(5, False, 1, 1).data(1)
    bus.t += 20_000
    bus.cmd(5, False, 1, 1, bus=1).data(1, bus=1).status(5, bus=1)
    first, second = assemble(bus.words())
    assert (first.bus, first.errors) == ("A", ("no_response",))
    assert (second.bus, second.errors) == ("B", ())


def test_both_buses_active_at_once() -> None:
    bus = Bus().cmd(5, True, 1, 2).status(5).data(1, 2)
    bus.t = 1_000 + 30_000
    bus.cmd(6, True, 31, 2, idle_us=0, bus=1).status(6, bus=1)
    records = assemble(bus.words())
    assert all("both_buses_active" in r.errors for r in records)


def test_without_time_tags_an_overlap_is_not_judged() -> None:
    """A word card without time tags (the serial card) places words in host time: an overlap
    there says nothing about the bus, as a response time says nothing (under load a retry on
    bus B arrived in the host time of the message it retried and was flagged)."""
    bus = Bus().cmd(5, True, 1, 2).status(5).data(1, 2)
    bus.t = 1_000 + 30_000
    bus.cmd(6, True, 31, 2, idle_us=0, bus=1).status(6, bus=1)
    assembler = MessageAssembler(time_tags=False)
    records = assembler.feed(bus.words()) + assembler.flush()
    assert len(records) == 2 and all(r.errors == () for r in records)


def traffic(seed: int, messages: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bus = Bus()
    for _ in range(messages):
        kind = int(rng.integers(4))
        if kind == 0:
            bus.cmd(5, False, 1, 3).data(1, 2, 3).status(5)
        elif kind == 1:
            bus.cmd(7, True, 2, 2).status(7).data(4, 5)
        elif kind == 2:
            bus.cmd(5, False, 1, 1).data(1)  # no response
            bus.t += 20_000
        else:
            bus.cmd(6, False, 3, 1).cmd(7, True, 3, 1, idle_us=0).status(7).data(8).status(6)
    return bus.words()


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 1000), cuts=st.lists(st.integers(0, 400), max_size=8))
def test_streaming_in_any_batches_equals_one_call(seed: int, cuts: list[int]) -> None:
    words = traffic(seed, 60)
    whole = assemble(words)
    assembler = MessageAssembler()
    records: list[MonitorRecord] = []
    start = 0
    for cut in sorted({c for c in cuts if c < words.size}):
        records += assembler.feed(words[start:cut])
        start = cut
    records += assembler.feed(words[start:]) + assembler.flush()
    assert [r.to_json() for r in records] == [r.to_json() for r in whole]


def test_horizon_closes_a_silent_no_response() -> None:
    words = Bus().cmd(5, False, 1, 1).data(1).words()
    assembler = MessageAssembler()
    assert assembler.feed(words) == []  # the status may still come
    last_end = int(words["end_ns"][-1])
    (record,) = assembler.feed(empty_words(), horizon_ns=last_end + 15_000)
    assert record.errors == ("no_response",)


def test_both_buses_active_marks_what_a_span_by_span_test_marks() -> None:
    """Overlapping traffic on both buses: each message is flagged exactly when one of the
    other bus's last 64 spans (recent and this call's) overlaps it, as a plain loop says."""
    from drivers.mil1553.wordbatch import make_words

    rows = []
    for k in range(300):   # 2-word BC-RT messages, bus B shifted so some overlap bus A's
        for bus, shift in ((0, 0), (1, 7_000 + (k // 50) * 200_000)):
            t = k * 120_000 + shift
            rows += [(t, bus, 1, 0x2822), (t + 20_000, bus, 0, k), (t + 40_000, bus, 0, 1),
                     (t + 66_000, bus, 1, 0x2800)]
    words = make_words(sorted(rows))
    plain = MessageAssembler()
    raw: list[MonitorRecord] = []
    for start in range(0, words.size, 333):
        raw += plain.feed(words[start:start + 333])
    flagged = [r for r in raw if "both_buses_active" in r.errors]
    assert flagged and len(flagged) < len(raw)
    # the same calls again, each message's flag recomputed span by span
    again = MessageAssembler()
    recent: dict[str, list[tuple[int, int]]] = {"A": [], "B": []}
    for start in range(0, words.size, 333):
        got = again.feed(words[start:start + 333])
        spans = {b: [*recent[b], *((r.t_ns, r.end_ns) for r in got if r.bus == b)]
                 for b in "AB"}
        for r in got:
            other = spans["B" if r.bus == "A" else "A"][-64:]
            expected = any(s < r.end_ns and e > r.t_ns for s, e in other)
            assert ("both_buses_active" in r.errors) == expected
        recent = {b: spans[b][-8:] for b in "AB"}
