"""The monitor's batch API: ``recv_batch()`` / ``batches()`` hand out, as numpy columns, the
very messages ``recv()`` and iteration hand out as records, filters and statistics included.

The recording is made with the project's own Chapter 10 writer: both buses, BC-RT, RT-BC,
RT-RT (both directions of a terminal), mode codes, time-outs, several seconds (time packets)
and small batches (``BATCH_MESSAGES`` lowered) so that a run spans many of them.
"""

from __future__ import annotations

from datetime import datetime
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import drivers.backends.chapter10 as chapter10_backend
from drivers.chapter10.ms1553_batch import Ms1553Batch
from drivers.chapter10.writer import Chapter10Writer
from drivers.errors import MonitorClosed
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.mil1553.words import CommandWord, StatusWord
from drivers.monitor import MonitorFilter, open_monitor

GOLDEN = Path(__file__).parents[1] / "data" / "codec" / "golden-10MSps.bin"
SEED = 27


def traffic(n: int, seed: int = SEED) -> list[MonitorRecord]:
    """``n`` messages 2 ms apart (seeded): a mix of every shape a monitor meets."""
    rng = np.random.default_rng(seed)
    records = []
    for i in range(n):
        t, bus = i * 2_000_000, "AB"[int(rng.integers(2))]
        rt, other = int(rng.integers(1, 8)), int(rng.integers(8, 12))
        sa, count = int(rng.integers(1, 30)), int(rng.integers(1, 33))
        data = tuple(int(w) for w in rng.integers(0, 1 << 16, count))
        kind = int(rng.integers(5))
        if kind == 0:
            records.append(MonitorRecord(t, bus, TransferFormat.BC_RT,
                                         CommandWord(rt, False, sa, count % 32).value,
                                         data=data, status=(StatusWord(rt).value,),
                                         gaps_ns=(8_000,)))
        elif kind == 1:
            records.append(MonitorRecord(t, bus, TransferFormat.RT_BC,
                                         CommandWord(rt, True, sa, count % 32).value,
                                         data=data, status=(StatusWord(rt).value,),
                                         gaps_ns=(6_000,)))
        elif kind == 2:   # RT-RT, the receiving or the transmitting terminal being ``rt``
            rx, tx = (rt, other) if rng.integers(2) else (other, rt)
            records.append(MonitorRecord(
                t, bus, TransferFormat.RT_RT, CommandWord(rx, False, sa, count % 32).value,
                command2=CommandWord(tx, True, (sa + 3) % 30 + 1, count % 32).value,
                data=data, status=(StatusWord(tx).value, StatusWord(rx).value),
                gaps_ns=(8_000, 9_000)))
        elif kind == 3:
            records.append(MonitorRecord(t, bus, TransferFormat.MODE,
                                         CommandWord(rt, True, 0, 2).value,
                                         status=(StatusWord(rt).value,), gaps_ns=(7_000,)))
        else:   # a terminal that does not answer
            records.append(MonitorRecord(t, bus, TransferFormat.BC_RT,
                                         CommandWord(rt, False, sa, count % 32).value,
                                         data=data, errors=("no_response",)))
    return records


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("batches") / "mixed.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 1, 1)) as writer:
        writer.write(traffic(3000))
    return path


@pytest.fixture(autouse=True)
def small_batches(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(chapter10_backend, "BATCH_MESSAGES", 100)


def same(a: list[MonitorRecord], b: list[MonitorRecord]) -> None:
    """Equal message for message, ``extra`` (channel, block status, time) included."""
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x == y
        assert x.extra == y.extra


def records_of(path: Path, **options: Any) -> tuple[list[MonitorRecord], dict[str, Any]]:
    with open_monitor("chapter10", path=str(path), **options) as monitor:
        records = list(monitor)
        return records, monitor.stats.as_dict()


def batches_of(path: Path, **options: Any) -> tuple[list[Ms1553Batch], dict[str, Any]]:
    with open_monitor("chapter10", path=str(path), **options) as monitor:
        batches = list(monitor.batches())
        assert monitor.ended
        return batches, monitor.stats.as_dict()


def test_batches_are_the_records_message_for_message(recording: Path) -> None:
    records, stats = records_of(recording)
    batches, batch_stats = batches_of(recording)
    assert len(records) == 3000 and len(batches) > 10
    assert all(isinstance(b, Ms1553Batch) and len(b) for b in batches)
    same([r for b in batches for r in b.records()], records)
    assert batch_stats == stats
    # the columns themselves say what the records say
    t_ns = np.concatenate([b.t_ns for b in batches])
    assert t_ns.tolist() == [r.t_ns for r in records]
    rts = np.concatenate([b.rt for b in batches])
    assert rts.tolist() == [r.rt for r in records]
    assert [str(t) for b in batches for t in b.time] == [r.extra["time"] for r in records]
    assert {r.extra["channel"] for r in records} == {1}


FILTERS = [
    [MonitorFilter(rt=3)],
    [MonitorFilter(rt=3, tr="T")],             # RT 3 transmits: RT-BC and RT-RT as sender
    [MonitorFilter(rt=3, tr="R")],
    [MonitorFilter(rt=frozenset({2, 9}), sa=5)],
    [MonitorFilter(format="rt_rt", error=False)],
    [MonitorFilter(error="no_response")],
    [MonitorFilter(error=True, rt=4)],
    [MonitorFilter(start_ns=1_000_000_000, end_ns=3_000_000_000)],
    [MonitorFilter(format=frozenset({"MODE", "RT_BC"})), MonitorFilter(rt=8, tr="T")],
]


@pytest.mark.parametrize("filters", FILTERS, ids=repr)
def test_filters_apply_equally_to_records_and_batches(recording: Path,
                                                      filters: list[MonitorFilter]) -> None:
    everything, _ = records_of(recording)
    expected = [r for r in everything if any(f.matches(r) for f in filters)]
    assert 0 < len(expected) < len(everything)
    records, stats = records_of(recording, filters=filters)
    batches, batch_stats = batches_of(recording, filters=filters)
    same(records, expected)
    same([r for b in batches for r in b.records()], expected)
    assert stats == batch_stats   # every message counted, filtered or not
    for f in filters:   # the mask is matches() over columns
        for batch in batches_of(recording)[0]:
            assert f.mask(batch).tolist() == [f.matches(r) for r in batch.records()]


def test_recv_and_recv_batch_mix_each_message_handed_out_once(recording: Path) -> None:
    everything, stats = records_of(recording)
    with open_monitor("chapter10", path=str(recording)) as monitor:
        taken: list[MonitorRecord] = []
        for _ in range(3):
            record = monitor.recv()
            assert record is not None
            taken.append(record)
        assert monitor.stats.as_dict()["A"]["messages"] + \
            monitor.stats.as_dict().get("B", {"messages": 0})["messages"] == 3
        rest = monitor.recv_batch()   # the rest of the batch the three came from
        assert rest is not None and rest.t_ns[0] == everything[3].t_ns
        taken += rest.records()
        taken += list(islice(monitor, 50))   # iteration left off mid-batch
        taken.append(monitor.recv())  # type: ignore[arg-type]
        while (batch := monitor.recv_batch()) is not None:
            taken += batch.records()
        assert monitor.ended
        assert monitor.stats.as_dict() == stats
    same(taken, everything)


def test_filters_changed_mid_batch_apply_from_there_on(recording: Path) -> None:
    everything, _ = records_of(recording)
    rt3 = MonitorFilter(rt=3)
    with open_monitor("chapter10", path=str(recording)) as monitor:
        first = [monitor.recv() for _ in range(10)]
        monitor.set_filters([rt3])
        rest = list(monitor)
    assert first == everything[:10]
    assert rest == [r for r in everything[10:] if rt3.matches(r)]


def test_records_a_backend_makes_are_packed_into_the_same_columns() -> None:
    """A backend without columns (a bit-level capture: stray words, word errors) gives
    batches whose records are its records."""
    options = {"path": str(GOLDEN), "sample_rate": 10e6}
    with open_monitor("capture", **options) as monitor:
        records = list(monitor)
        stats = monitor.stats.as_dict()
    assert any(r.command is None for r in records) and any(r.word_errors for r in records)
    with open_monitor("capture", **options) as monitor:
        batches = list(monitor.batches())
        assert monitor.stats.as_dict() == stats
    same([r for b in batches for r in b.records()], records)
    assert Ms1553Batch.from_records(records).records() == records
    unknown = Ms1553Batch.from_records([r for r in records if r.command is None])
    assert (unknown.command == -1).all()
    errors = [MonitorFilter(error="parity")]
    with open_monitor("capture", filters=errors, **options) as monitor:
        flagged = [r for b in monitor.batches() for r in b.records()]
    assert flagged == [r for r in records if "parity" in r.errors] != []


def test_paced_replay_batches_too(recording: Path) -> None:
    everything, _ = records_of(recording)
    with open_monitor("chapter10", path=str(recording), speed=1e6) as monitor:
        paced = [r for b in monitor.batches() for r in b.records()]
    same(paced, everything)


def test_time_out_end_and_close(recording: Path) -> None:
    with open_monitor("chapter10", path=str(recording),
                      filters=[MonitorFilter(rt=31)]) as monitor:   # nothing matches
        assert monitor.recv_batch() is None and monitor.ended
    monitor = open_monitor("chapter10", path=str(recording))
    monitor.close()
    with pytest.raises(MonitorClosed):
        monitor.recv_batch()
    with pytest.raises(MonitorClosed):
        next(iter(monitor))
