"""Per-RT/SA statistics and windowed bus load (drivers.rtstats), on records built by hand."""

from __future__ import annotations

import pytest

from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.rtstats import TrafficStatistics


def cmd(rt: int, tr: str, sa: int, wc: int) -> int:
    return rt << 11 | (tr == "T") << 10 | sa << 5 | (wc & 31)


def bc_rt(t_ns: int, rt: int, sa: int, wc: int, gap: int | None = 6000,
          errors: tuple[str, ...] = (), bus: str = "A") -> MonitorRecord:
    return MonitorRecord(t_ns=t_ns, bus=bus, format=TransferFormat.BC_RT,
                         command=cmd(rt, "R", sa, wc), data=(0,) * wc,
                         status=() if gap is None else (rt << 11,),
                         gaps_ns=() if gap is None else (gap,), errors=errors)


def by_label(stats: TrafficStatistics) -> dict[str, object]:
    return {r.label: r for r in stats.rows()}


def test_counts_rate_response_errors_and_last_seen() -> None:
    records = [bc_rt(i * 10_000_000, 5, 1, 3, gap=5000 + 100 * i) for i in range(11)]
    records.append(bc_rt(55_000_000, 5, 1, 3, gap=None, errors=("no_response",)))
    stats = TrafficStatistics()
    stats.add_batch(records)
    (row,) = stats.rows()
    assert row.label == "RT05 R SA01" and row.wc == 3
    assert row.messages == 12
    assert row.rate_hz == pytest.approx(12 / 0.1)          # 12 messages over 100 ms observed
    assert row.errors == {"no_response": 1}
    assert (row.response_min_us, row.response_max_us) == (5.0, 6.0)
    assert row.response_mean_us == pytest.approx(5.5)       # the silent one has no gap
    assert row.last_ns == 100_000_000 and row.first_ns == 0


def test_mode_codes_rt_rt_and_unknown_errors_have_their_own_keys() -> None:
    mode = MonitorRecord(t_ns=0, bus="B", format=TransferFormat.MODE,
                         command=cmd(7, "T", 31, 2), status=(7 << 11,), gaps_ns=(7000,))
    rtrt = MonitorRecord(t_ns=1000, bus="A", format=TransferFormat.RT_RT,
                         command=cmd(6, "R", 12, 4), command2=cmd(2, "T", 12, 4),
                         data=(1, 2, 3, 4), status=(2 << 11, 6 << 11), gaps_ns=(5700, 6500),
                         errors=("something_new",))
    stats = TrafficStatistics()
    stats.add_batch([mode, rtrt])
    rows = by_label(stats)
    assert set(rows) == {"RT07 T MC02", "RT06 R SA12", "RT02 T SA12"}
    mc = stats.rows()[-1]
    assert mc.mode_code == 2 and mc.sa == 31 and mc.wc is None
    assert mc.as_dict()["mode"] and mc.response_mean_us == 7.0
    rx, tx = rows["RT06 R SA12"], rows["RT02 T SA12"]
    assert rx.response_mean_us == 6.5 and tx.response_mean_us == 5.7   # each its own gap
    assert rx.errors == tx.errors == {"other": 1}
    assert stats.rt_rt == {(cmd(6, "R", 12, 0), cmd(2, "T", 12, 0)): 1}


def test_batches_add_up_to_the_same_as_one_batch() -> None:
    records = [bc_rt(i * 1_000_000, rt, sa, 1 + i % 5, gap=5000 + i,
                     errors=("parity",) if i % 7 == 0 else ())
               for i, (rt, sa) in enumerate([(1, 2), (3, 4), (1, 2), (9, 30)] * 25)]
    whole, parts = TrafficStatistics(), TrafficStatistics()
    whole.add_batch(records)
    for k in range(0, len(records), 13):
        parts.add_batch(records[k:k + 13])
    assert whole.rows() == parts.rows() and whole.windows() == parts.windows()
    row = by_label(whole)["RT01 R SA02"]
    assert row.wc == 5 and row.wc_min == 1 and "5*" in whole.table()


def test_windowed_load_per_bus() -> None:
    # a 32-word BC-RT message is 34 words = 680 µs; three of them in the first 10 ms on A,
    # one on B, one on A in the next window, and a stray word (no command) on A
    records = [bc_rt(t, 5, 1, 32, bus=bus) for t, bus in
               ((0, "A"), (2_000_000, "A"), (4_000_000, "A"), (1_000_000, "B"),
                (12_000_000, "A"))]
    records.append(MonitorRecord(t_ns=13_000_000, bus="A", format=TransferFormat.UNKNOWN,
                                 command=None, data=(5,), errors=("orphan_words",)))
    stats = TrafficStatistics(window_ns=10_000_000)
    stats.add_batch(records)
    loads = [(w.bus, w.start_ns, round(w.load_percent, 2)) for w in stats.windows()]
    # observed: from 0 to the end of the stray word (13 ms + 20 µs)
    assert loads == [("A", 0, 20.4), ("B", 0, 6.8), ("A", 10_000_000, round(100 * 700 / 3020, 2))]
    assert stats.unkeyed == 1 and sum(r.messages for r in stats.rows()) == 5
    kinds = [line["kind"] for line in stats.json_lines()]
    assert kinds == ["rtsa"] + ["bus_load"] * 3


def test_empty_and_bad_window() -> None:
    stats = TrafficStatistics()
    stats.add_batch([])
    assert stats.rows() == [] and stats.windows() == []
    with pytest.raises(ValueError, match="positive"):
        TrafficStatistics(window_ns=0)
