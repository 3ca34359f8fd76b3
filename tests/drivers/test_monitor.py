"""The BusMonitor API: filters, statistics, errors, the backend table, the capture backend."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.errors import BackendError, BackendUnavailable, MonitorClosed
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.monitor import (
    BACKENDS,
    BusMonitor,
    MonitorFilter,
    available_backends,
    backend_class,
    open_monitor,
)

GOLDEN = Path(__file__).parents[1] / "data" / "codec" / "golden-10MSps.bin"


def rec(t: int, bus: str = "A", command: int = 0x2822, errors: tuple[str, ...] = (),
        fmt: TransferFormat = TransferFormat.BC_RT) -> MonitorRecord:
    return MonitorRecord(t_ns=t, bus=bus, format=fmt, command=command, data=(1, 2),
                         status=(0x2800,), errors=errors, end_ns=t + 80_000)


class ScriptedMonitor(BusMonitor):
    """A backend that hands out prepared batches, then fails, then ends."""

    def __init__(self, batches: list[object], **kw: object) -> None:
        super().__init__(**kw)  # type: ignore[arg-type]
        self.batches = list(batches)
        self.closes = 0

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if not self.batches:
            return None
        item = self.batches.pop(0)
        if isinstance(item, Exception):
            raise item
        return item  # type: ignore[return-value]

    def _close(self) -> None:
        self.closes += 1


def test_iteration_statistics_and_end_of_stream() -> None:
    monitor = ScriptedMonitor([[rec(0), rec(100_000, "B")], [], [rec(200_000)]])
    assert [r.t_ns for r in monitor] == [0, 100_000, 200_000]
    assert monitor.ended
    assert monitor.stats.messages == {"A": 2, "B": 1}
    assert monitor.stats.words["A"] == 8  # command, two data words, status, twice
    assert 0 < monitor.stats.load("A") <= 100


def test_statistics_stop_at_the_last_record_handed_out() -> None:
    """A consumer that stops after three records (``mapr monitor --count 3 --stats``) reads
    statistics of those three, not of the whole batch the backend delivered at once."""
    monitor = ScriptedMonitor([[rec(t * 100_000) for t in range(13)]])
    taken = [monitor.recv() for _ in range(3)]
    assert all(r is not None for r in taken)
    assert monitor.stats.messages == {"A": 3}
    filtered = ScriptedMonitor([[rec(0, command=0x2822), rec(1, command=0x3022),
                                 rec(2, command=0x2822), rec(3, command=0x3022)]],
                               filters=[MonitorFilter(rt=6)])
    assert filtered.recv().t_ns == 1  # type: ignore[union-attr]
    assert filtered.stats.messages == {"A": 2}, "the skipped record on the way counts too"


def test_filters_combine_as_python_can_does() -> None:
    records = [rec(0, command=0x2822), rec(1, command=0x3022, errors=("no_response",)),
               rec(2, command=0x2C22, fmt=TransferFormat.RT_BC)]
    monitor = ScriptedMonitor([records], filters=[MonitorFilter(rt=6), MonitorFilter(tr="T")])
    assert [r.t_ns for r in monitor] == [1, 2]
    only_errors = ScriptedMonitor([records], filters=[MonitorFilter(error=True)])
    assert [r.t_ns for r in only_errors] == [1]
    by_name = ScriptedMonitor([records], filters=[MonitorFilter(error="no_response", rt=6)])
    assert [r.t_ns for r in by_name] == [1]
    clean_bc_rt = ScriptedMonitor([records], filters=[MonitorFilter(format="bc_rt",
                                                                    error=False)])
    assert [r.t_ns for r in clean_bc_rt] == [0]
    assert monitor.stats.messages["A"] == 3, "statistics count every record, filtered or not"


def test_a_backend_failure_reaches_the_caller_and_keeps_what_was_received() -> None:
    monitor = ScriptedMonitor([[rec(0), rec(1)], OSError("device unplugged"), [rec(2)]])
    assert monitor.recv().t_ns == 0  # type: ignore[union-attr]
    assert monitor.recv().t_ns == 1  # type: ignore[union-attr]
    with pytest.raises(BackendError, match="device unplugged"):
        monitor.recv()
    assert monitor.recv().t_ns == 2  # type: ignore[union-attr]


def test_timeout_returns_none_and_close_is_idempotent() -> None:
    monitor = ScriptedMonitor([[], [], [rec(5)]])
    assert monitor.recv(timeout=0) is None
    with monitor:
        pass
    monitor.close()
    assert monitor.closes == 1 and monitor.closed
    with pytest.raises(MonitorClosed):
        monitor.recv()


def test_backend_table_and_unknown_backends() -> None:
    assert {"loopback", "capture"} <= set(available_backends())
    assert set(BACKENDS) <= set(available_backends())
    with pytest.raises(BackendUnavailable, match="unknown backend 'nosuch'"):
        open_monitor("nosuch")
    with pytest.raises(TypeError, match="bogus"):
        open_monitor("capture", path=str(GOLDEN), sample_rate=10e6, bogus=1)


def test_a_backend_whose_dependency_is_missing_is_unavailable_not_fatal(monkeypatch) -> None:
    monkeypatch.setitem(BACKENDS, "needs-missing",
                        ("drivers.backends.module_that_does_not_exist", "X"))
    with pytest.raises(BackendUnavailable, match="needs-missing"):
        backend_class("needs-missing")
    assert backend_class("capture").__name__ == "CaptureMonitor"


def test_capture_backend_replays_a_file_like_the_bus() -> None:
    with open_monitor("capture", path=str(GOLDEN), sample_rate=10e6) as monitor:
        records = list(monitor)
    first = records[0]
    assert (str(first.format), first.rt, first.sa, list(first.data)) == \
        ("BC_RT", 5, 1, [0x8000, 0x7FFF])
    assert first.errors == ()
    assert str(records[1].format) == "RT_BC" and records[1].bus == "B"
    flagged = {e for r in records for e in r.errors}
    assert {"parity", "manchester", "bit_count_low", "bit_count_high"} <= flagged


def test_recv_after_close_raises_even_with_records_queued() -> None:
    """A backend that delivers several records in one batch (a serial card read while the
    host was busy): after close(), recv() raises at once rather than handing out the rest of
    that batch, however the records were batched."""
    monitor = ScriptedMonitor([[rec(1), rec(2), rec(3)]])
    assert monitor.recv().t_ns == 1  # type: ignore[union-attr]
    monitor.close()
    with pytest.raises(MonitorClosed):
        monitor.recv()


@pytest.mark.parametrize("end_ns", [0, 19_500, 20_000, 31_000],
                         ids=["no end", "end before the word's", "end at it", "end after it"])
def test_a_span_of_one_message_is_at_most_100_percent_busy(end_ns: int) -> None:
    """One stray word (20 µs on the bus) whose recorded end comes before its word's end (the
    capture's mid-crossing timing: 102.6 % before), or that has no end: the span runs from its
    start to its end, and never ends before its words do."""
    from drivers.monitor import BusStatistics

    stats = BusStatistics()
    stats.add(MonitorRecord(t_ns=280_000, bus="A", format=TransferFormat.UNKNOWN,
                            command=None, data=(0x1234,), errors=("orphan_words",),
                            end_ns=280_000 + end_ns if end_ns else 0))
    assert stats.load("A") == pytest.approx(100.0 * 20_000 / max(end_ns, 20_000))


def test_bus_load_of_records_and_of_columns_agree_and_stay_within_the_span() -> None:
    """Two buses, each message's recorded end short of its words' (as a capture's timing can
    be): each bus's busy time lies in the span, counted record by record or as columns."""
    from drivers.chapter10.ms1553_batch import Ms1553Batch
    from drivers.monitor import BusStatistics

    records = [MonitorRecord(t_ns=t, bus=bus, format=TransferFormat.BC_RT, command=0x2822,
                             data=(1, 2), status=(0x2800,), end_ns=t + 70_000)
               for t, bus in ((0, "A"), (80_000, "A"), (160_000, "B"))]
    one, columns = BusStatistics(), BusStatistics()
    for record in records:
        one.add(record)
    columns.add_columns(Ms1553Batch.from_records(records))
    span = 160_000 + 4 * 20_000
    assert one.load("A") == columns.load("A") == pytest.approx(100.0 * 8 * 20_000 / span)
    assert one.load("B") == columns.load("B") == pytest.approx(100.0 * 4 * 20_000 / span)
