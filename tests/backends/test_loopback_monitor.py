"""The loopback backend as a monitor: default traffic, determinism, paths, pacing, options."""

from __future__ import annotations

import time
from collections import Counter

import pytest

from drivers.backends.loopback import (
    Injection,
    LoopbackMonitor,
    RemoteTerminal,
    Schedule,
    bc_rt,
    rt_bc,
    schedule_from_slots,
)
from drivers.errors import BackendError
from drivers.mil1553.encoder import Impairments
from drivers.monitor import MonitorFilter, open_monitor


def test_default_traffic_is_clean_and_shows_every_format() -> None:
    with open_monitor("loopback", frames=100) as monitor:
        records = list(monitor)
    assert len(records) > 150
    assert all(r.errors == () for r in records), [r.to_json() for r in records if r.errors]
    assert len(Counter(str(r.format) for r in records)) == 10
    assert monitor.stats.as_dict()["A"]["messages"] == len(records)


def test_clean_traffic_with_receiver_tolerance_impairments() -> None:
    impaired = Impairments(rate_error=8e-4, jitter_ns=100.0, dead_band_ns=60.0)
    records = list(LoopbackMonitor(frames=60, impairments=impaired, seed=7))
    assert len(records) > 100 and all(r.errors == () for r in records)


def test_word_level_and_bit_level_give_the_same_messages() -> None:
    injections = [Injection("parity", rt=5, sa=10), Injection("late_response", rt=6),
                  Injection("no_response", format="MODE_TX_DATA")]
    fast = list(LoopbackMonitor(frames=60, bit_level=False, injections=list(injections)))
    injections = [Injection("parity", rt=5, sa=10), Injection("late_response", rt=6),
                  Injection("no_response", format="MODE_TX_DATA")]
    slow = list(LoopbackMonitor(frames=60, injections=injections))

    def key(r: object) -> tuple[object, ...]:
        j = r.to_json()  # type: ignore[attr-defined]
        return (j["bus"], j["format"], j.get("rt"), j.get("sa"), j["data"], j["status"],
                j["errors"])
    assert [key(r) for r in fast] == [key(r) for r in slow]
    assert all(abs(a.t_ns - b.t_ns) < 100 for a, b in zip(fast, slow, strict=True))


def test_equal_seeds_give_equal_records() -> None:
    def run(seed: int) -> list[dict[str, object]]:
        monitor = LoopbackMonitor(frames=20, seed=seed, impairments=Impairments(jitter_ns=80.0),
                                  injections=[Injection("noise", count=None)])
        return [r.to_json() for r in monitor]
    assert run(1) == run(1)


def test_duration_bounds_bus_time_and_each_recv_is_one_frame() -> None:
    monitor = LoopbackMonitor(duration_s=0.01, bit_level=False)
    assert monitor._recv_internal(None) is not None
    assert monitor.bus_time_ns == 2_000_000
    list(monitor)
    assert monitor.bus_time_ns == 10_000_000


def test_realtime_pacing_follows_the_wall_clock() -> None:
    started = time.monotonic()
    records = list(LoopbackMonitor(duration_s=0.1, realtime=True, bit_level=False))
    assert time.monotonic() - started >= 0.08
    assert records
    opened = time.monotonic()
    monitor = LoopbackMonitor(realtime=True, bit_level=False)
    for _ in range(20):
        monitor.recv(timeout=0.01)
        # never ahead of the wall clock by more than the frame being played (2 ms), however
        # late this host runs (running late only puts the bus behind)
        assert monitor.bus_time_ns <= (time.monotonic() - opened) * 1e9 + 2_000_000
    monitor.close()


def test_filters_and_one_off_messages() -> None:
    monitor = LoopbackMonitor(frames=3, bit_level=False, filters=[MonitorFilter(rt=9)],
                              terminals=[RemoteTerminal(9)],
                              schedule=Schedule((rt_bc(9, 1, 1),), frame_ns=200_000))
    monitor.send(bc_rt(9, 2, 2))
    records = list(monitor)
    assert [str(r.format) for r in records] == ["RT_BC", "BC_RT", "RT_BC", "RT_BC"]


def test_schedule_from_plain_rows() -> None:
    schedule = schedule_from_slots(2000, [(5, 1, 10, 29, 1, 0), (5, 0, 1, 3, 5, 0)])
    assert schedule.frame_ns == 2_000_000
    assert [m.label for m in schedule.frame(0)] == ["RT05 T SA10 WC29", "RT05 R SA01 WC03"]
    assert len(schedule.frame(1)) == 1


def test_a_callback_with_the_wrong_word_count_reaches_the_caller() -> None:
    rt = RemoteTerminal(5, transmit={1: lambda t_ns: [1, 2]})
    monitor = LoopbackMonitor(terminals=[rt], bit_level=False,
                              schedule=Schedule((rt_bc(5, 1, 3),), frame_ns=200_000))
    with pytest.raises(BackendError, match="2 words for a 3-word command"):
        monitor.recv(timeout=1.0)


@pytest.mark.parametrize("bad", [
    lambda: RemoteTerminal(31), lambda: RemoteTerminal(3, transmit={0: lambda t: []}),
    lambda: Injection("gremlins"), lambda: Injection("parity", format="CAN"),
    lambda: Schedule((), frame_ns=10), lambda: rt_bc(5, 1, 33),
    lambda: LoopbackMonitor(colour="red"),
])
def test_bad_configuration_is_refused(bad: object) -> None:
    with pytest.raises((ValueError, TypeError)):
        bad()  # type: ignore[operator]
