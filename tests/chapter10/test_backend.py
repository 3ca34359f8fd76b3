"""The ``chapter10`` backend through the monitor API: open_monitor, filters, statistics, pace."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from drivers.monitor import MonitorFilter, available_backends, open_monitor

RT_BC = (5 << 11 | 1 << 10 | 1 << 5 | 1, 5 << 11, 0x1234)


def test_the_backend_is_registered() -> None:
    assert "chapter10" in available_backends()


def test_the_sample_through_open_monitor_with_statistics(sample_c10: Path) -> None:
    with open_monitor("chapter10", path=str(sample_c10)) as monitor:
        records = list(monitor)
        assert monitor.ended
        stats = monitor.stats.as_dict()
    assert len(records) == 475
    assert stats["A"]["messages"] == 306 and stats["B"]["messages"] == 169
    assert stats["A"]["errors"]["no_response"] + stats["B"]["errors"]["no_response"] == 27
    assert stats["A"]["words"] + stats["B"]["words"] == sum(
        (r.command is not None) + (r.command2 is not None) + len(r.data) + len(r.status)
        for r in records)
    assert 0 < stats["A"]["load_percent"] < 100


def test_channels_and_filters(sample_c10: Path) -> None:
    with open_monitor("chapter10", path=str(sample_c10), channels=[3, 5]) as monitor:
        channels = {r.extra["channel"] for r in monitor}
    assert channels == {3, 5}
    with open_monitor("chapter10", path=str(sample_c10),
                      filters=[MonitorFilter(error="no_response")]) as monitor:
        timed_out = list(monitor)
    assert len(timed_out) == 27 and all(not r.status for r in timed_out)


@pytest.mark.parametrize("channels", [[3, 5], "3,5", (3, 5)])
def test_channels_as_a_list_or_as_text(sample_c10: Path, channels: Any) -> None:
    with open_monitor("chapter10", path=str(sample_c10), channels=channels) as monitor:
        assert {r.extra["channel"] for r in monitor} == {3, 5}
    with open_monitor("chapter10", path=str(sample_c10), channels=4) as monitor:
        assert {r.extra["channel"] for r in monitor} == {4}


def test_damage_is_logged_and_the_replay_goes_on(c10: Any, tmp_path: Path,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    good = c10.ms1553([c10.Message(RT_BC, ipts=100)])
    path = tmp_path / "bad.c10"
    path.write_bytes(good + b"\x00" * 24 + good)
    with caplog.at_level(logging.WARNING), \
            open_monitor("chapter10", path=str(path)) as monitor:
        records = list(monitor)
        issues = [str(i) for i in monitor.issues]  # type: ignore[attr-defined]
    assert len(records) == 2
    assert issues == [f"offset {len(good)}: bad sync pattern 0x0000 (expected 0xEB25)"]
    assert f"bad.c10: offset {len(good)}: bad sync pattern" in caplog.text


def test_paced_replay_waits_for_recorded_time(c10: Any, tmp_path: Path) -> None:
    # two messages 50 s apart in recorded time
    path = tmp_path / "paced.c10"
    path.write_bytes(c10.ms1553([c10.Message(RT_BC, ipts=0)]) +
                     c10.ms1553([c10.Message(RT_BC, ipts=500_000_000)]))
    with open_monitor("chapter10", path=str(path), speed=1.0) as monitor:
        assert monitor.recv() is not None   # the first is due at once
        assert monitor.recv(timeout=0.05) is None  # the second is 50 s away
        assert not monitor.ended
    with open_monitor("chapter10", path=str(path), speed=1000.0) as monitor:
        assert len(list(monitor)) == 2  # 50 ms at a thousand times the pace
    with open_monitor("chapter10", path=str(path), speed=0) as monitor:
        assert len(list(monitor)) == 2


def test_bad_options_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="speed"):
        open_monitor("chapter10", path=str(tmp_path / "x.c10"), speed=-1)
    with pytest.raises(ValueError, match="channel IDs such as 2,3"):
        open_monitor("chapter10", path=str(tmp_path / "x.c10"), channels="[2]")
    with pytest.raises(TypeError, match="unknown option"):
        open_monitor("chapter10", path=str(tmp_path / "x.c10"), bogus=1)
