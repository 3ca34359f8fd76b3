"""The compiled message grammar returns exactly the records of the Python reference grammar,
on random and adversarial word streams, whole or streamed in batches with horizons."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.mil1553.wordbatch import WordBatch, empty_words
from drivers.mil1553.words import CommandWord, StatusWord
from tests.support.assembler_reference import ReferenceAssembler

# Idle times between words (ns) around every threshold the grammar tests: contiguous, the
# break, early/late response, the time-out, the intermessage gap; and overlapping words.
IDLES = [0, 0, 0, 0, 300, 500, 501, 1_000, 1_999, 2_000, 2_001, 3_000, 6_000, 10_000,
         10_001, 12_000, 12_001, 20_000, 200_000, -5_000]


def _value(rng: np.random.Generator) -> int:
    kind = int(rng.integers(6))
    rt = int(rng.choice([5, 6, 31, int(rng.integers(32))]))
    if kind == 0:   # a normal command
        return CommandWord(rt, bool(rng.integers(2)), int(rng.integers(1, 4)),
                           int(rng.integers(0, 4))).value
    if kind == 1:   # a mode code, any
        return CommandWord(rt, bool(rng.integers(2)), int(rng.choice([0, 31])),
                           int(rng.integers(32))).value
    if kind == 2:   # a status, sometimes busy / message error / reserved bits
        word = StatusWord(rt, busy=bool(rng.integers(4) == 0),
                          message_error=bool(rng.integers(4) == 0)).value
        return word | (0x40 if rng.integers(8) == 0 else 0)
    return int(rng.integers(1 << 16))


def random_words(seed: int, size: int) -> WordBatch:
    """Words with random syncs, values, idle times, buses and word errors."""
    rng = np.random.default_rng(seed)
    words = empty_words(size)
    t = 1_000
    two_buses = bool(rng.integers(2))
    for i in range(size):
        t += int(rng.choice(IDLES))
        words[i]["t_ns"] = t
        words[i]["bus"] = int(rng.integers(2)) if two_buses else 0
        words[i]["sync"] = int(rng.integers(2))
        words[i]["value"] = _value(rng)
        words[i]["errors"] = int(rng.integers(32)) if rng.integers(10) == 0 else 0
        words[i]["end_ns"] = t + 19_500 + int(rng.choice([0, 0, 0, -3_000, 400]))
        t += 20_000
    order = np.argsort(words["t_ns"], kind="stable")
    sorted_words: WordBatch = words[order]
    return sorted_words


def run(assembler: MessageAssembler, words: WordBatch, cuts: list[int],
        horizons: list[int]) -> list[MonitorRecord]:
    """Feed ``words`` cut at ``cuts`` with horizons past each batch's end, then flush."""
    records: list[MonitorRecord] = []
    start = 0
    for n, cut in enumerate([*sorted({c for c in cuts if 0 < c < words.size}), words.size]):
        batch = words[start:cut]
        horizon = None
        if batch.size and horizons:
            horizon = int(batch["end_ns"].max()) + horizons[n % len(horizons)]
        records += assembler.feed(batch, horizon_ns=horizon)
        start = cut
    return records + assembler.flush()


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), size=st.integers(1, 120),
       cuts=st.lists(st.integers(0, 120), max_size=6),
       horizons=st.lists(st.sampled_from([0, 1_000, 5_000, 14_000, 20_000]), max_size=3),
       time_tags=st.booleans(), slack=st.sampled_from([500, 0, 3_000]))
def test_kernel_matches_the_reference_on_random_streams(
        seed: int, size: int, cuts: list[int], horizons: list[int], time_tags: bool,
        slack: int) -> None:
    words = random_words(seed, size)
    timing = BusTiming(contiguity_slack_ns=slack, babble_ns=100_000)
    got = run(MessageAssembler(timing, time_tags=time_tags), words, cuts, horizons)
    want = run(ReferenceAssembler(timing, time_tags=time_tags), words, cuts, horizons)
    assert got == want
    assert [r.to_json() for r in got] == [r.to_json() for r in want]
    assert sum(1 for r in got for _ in (*r.data, *r.status)) <= words.size


def test_kernel_matches_the_reference_on_adversarial_streams() -> None:
    """Hand-made edge cases: a superseding command, an RT-RT pair as superseder, busy with
    data, babbling, status words after the time-out, data after a break, empty feeds."""
    c = CommandWord
    s = StatusWord
    streams = [
        # (idle ns before, sync, value)
        [(0, 1, c(5, False, 1, 4).value), (0, 0, 1), (0, 1, c(6, False, 2, 1).value),
         (0, 0, 9), (6_000, 1, s(6).value)],
        [(0, 1, c(5, False, 1, 4).value), (0, 0, 1), (0, 1, c(6, False, 2, 1).value),
         (0, 1, c(7, True, 2, 1).value), (6_000, 1, s(7).value), (0, 0, 3)],
        [(0, 1, c(5, True, 1, 4).value), (6_000, 1, s(5, busy=True).value), (0, 0, 1)],
        [(0, 1, c(5, True, 1, 2).value), (6_000, 1, s(5).value), *[(0, 0, k) for k in range(50)]],
        [(0, 1, c(5, False, 1, 1).value), (0, 0, 1), (13_000, 1, s(5).value)],
        [(0, 1, c(5, False, 1, 2).value), (0, 0, 1), (3_000, 0, 2), (6_000, 1, s(5).value)],
        [(0, 0, 0xDEAD), (0, 0, 0xBEEF), (0, 1, c(31, True, 31, 1).value)],
        [(0, 1, c(31, False, 0, 17).value), (0, 0, 5), (1_000, 1, c(5, True, 31, 2).value),
         (6_000, 1, s(5).value)],
    ]
    for rows in streams:
        words = empty_words(len(rows))
        t = 0
        for i, (idle, sync, value) in enumerate(rows):
            t += idle
            words[i] = (t, 0, sync, value, 0, t + 19_500)
            t += 20_000
        for cuts in ([], [1], [2, 3], list(range(len(rows)))):
            for horizons in ([], [0], [14_000]):
                got = run(MessageAssembler(), words, cuts, horizons)
                want = run(ReferenceAssembler(), words, cuts, horizons)
                assert got == want, (rows, cuts, horizons)
    assert run(MessageAssembler(), empty_words(), [], []) == []


def test_new_records_build_the_constructors_records() -> None:
    """The assembler's bulk constructor: equal records, frozen, each its own ``extra``."""
    import dataclasses

    import pytest

    from drivers.mil1553.record import TransferFormat, new_records

    fields = (7, "B", TransferFormat.RT_RT, 0x3043, (1, 2), (0x2800, 0x3000), (8_000, 9_000),
              ("late_response",), 0x2C22, ((3, ("parity",)),), 99)
    columns = [[field] * 2 for field in fields]
    columns[1] = "B"  # one bus per call
    fast, other = new_records(*columns)  # type: ignore[arg-type]
    slow = MonitorRecord(*fields)
    assert fast == slow and repr(fast) == repr(slow) and fast.to_json() == slow.to_json()
    assert fast.extra == {} and fast.extra is not other.extra
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.t_ns = 8  # type: ignore[misc]
