"""``record:``: the daemon writes every record it sees to a Chapter 10 file per session, closed
cleanly on SIGTERM, and the file replays to the same traffic."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from drivers.chapter10.tmats import TAIL_ATTRIBUTE
from drivers.mil1553.record import MonitorRecord
from drivers.monitor import open_monitor
from mapr_daemon.fleet.archive import discover
from mapr_daemon.icd import load_icd
from mapr_daemon.service.config import Config
from mapr_daemon.service.recorder import SessionRecorder
from mapr_daemon.service.source import monitor_factory

if TYPE_CHECKING:   # the fixture's class; pytest loads conftest itself
    from tests.daemon.conftest import Daemon

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"
SESSION_FILES = r"(?:^|/)(?:(?P<tail>[^/]+)/)?session-(?P<flight>\d+)-[^/]*\.ch10$"
"""The daemon's file names to the fleet reader: the session as the flight, the TMATS's tail
or else a folder below the one given (the daemon writes them all in ``record.path``: read as
the archive, its files have no folder of their own)."""


def content(records: list[MonitorRecord]) -> list[tuple[object, ...]]:
    return [(r.bus, r.format, r.rt, r.sa, r.data, r.status, r.errors) for r in records]


def replay(path: Path) -> list[MonitorRecord]:
    with open_monitor("chapter10", path=str(path)) as monitor:
        return list(monitor)


def test_the_daemon_records_what_it_sees_and_closes_on_sigterm(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    recordings = tmp_path / "recordings"
    daemon = start_daemon(
        f"icd: {ICD}\ntestbed: {{realtime: false, duration_s: 0.6, seed: 4}}\n"
        f"catalog: {{path: {tmp_path / 'catalog.sqlite'}}}\n"
        f"record: {{path: {recordings}}}\naircraft: {{tail: N42MP}}\n")
    daemon.wait_log("stream ended", timeout=60)
    assert daemon.terminate()[0] == 0
    (file,) = recordings.iterdir()
    assert re.fullmatch(r"session-000001-\d{8}T\d{6}Z\.ch10", file.name)
    seen = int(re.findall(r"stopped: (\d+) messages", daemon.log)[-1])
    assert f"recorded {seen} messages to {file}" in daemon.log

    recorded = replay(file)
    config = Config(icd=str(ICD), testbed=dict(realtime=False, duration_s=0.6,
                                                        seed=4))
    with monitor_factory(config, load_icd(ICD))() as monitor:
        flown = list(monitor)
    assert len(recorded) == seen == len(flown)
    assert content(recorded) == content(flown)
    # bus time from 0, to the 100 ns the format keeps
    assert all(abs(a.t_ns - b.t_ns) <= 50 for a, b in zip(recorded, flown, strict=True))
    # the configured tail is in the file's TMATS, where the fleet reader finds it
    (found,), bad = discover([recordings], pattern=SESSION_FILES, tail_tmats=TAIL_ATTRIBUTE)
    assert (found.tail, found.flight, bad) == ("N42MP", 1, [])


def test_each_file_names_the_configured_tail_and_none_without_one(tmp_path: Path) -> None:
    """Every part of a session carries ``aircraft.tail`` as ``G\\TA``; a daemon with no
    tail writes none, and the fleet reader falls back to the path."""
    config = Config(icd=str(ICD), testbed=dict(realtime=False, duration_s=0.1))
    with monitor_factory(config, load_icd(ICD))() as monitor:
        flown = list(monitor)
    later = [dataclasses.replace(r, t_ns=r.t_ns + 2_000_000_000,
                                 end_ns=r.end_ns + 2_000_000_000) for r in flown]
    named = SessionRecorder(str(tmp_path / "box" / "named"), 3, tail="N77-TB")
    named.write(later)
    named.write(flown[:5])   # bus time from 0 again: a second part
    named.close()
    plain = SessionRecorder(str(tmp_path / "box" / "plain"), 4)
    plain.write(flown)
    plain.close()
    found, bad = discover([tmp_path / "box"], pattern=SESSION_FILES, tail_tmats=TAIL_ATTRIBUTE)
    assert not bad
    assert sorted((r.tail, r.flight, Path(r.path).name.endswith("part2.ch10"))
                  for r in found) == [("N77-TB", 3, False), ("N77-TB", 3, True),
                                      ("plain", 4, False)]
    assert content(replay(named.files[0])) == content(flown)
    assert content(replay(named.files[1])) == content(flown[:5])


def test_wall_clock_time_tags_are_rebased_and_a_restarted_bus_starts_a_new_part(
        tmp_path: Path) -> None:
    config = Config(icd=str(ICD), testbed=dict(realtime=False, duration_s=0.3))
    with monitor_factory(config, load_icd(ICD))() as monitor:
        flown = list(monitor)
    epoch = 1_778_300_000_250_000_000   # 2026-05-09T04:13:20.25Z, as a serial card stamps
    stamped = [dataclasses.replace(r, t_ns=r.t_ns + epoch, end_ns=r.end_ns + epoch)
               for r in flown]
    recorder = SessionRecorder(str(tmp_path / "rec"), 7)
    half = len(stamped) // 2
    recorder.write(stamped[:half])
    recorder.write(stamped[half:])
    recorder.write(flown[:10])   # the backend reopened: bus time from 0 again
    recorder.close()
    first, second = recorder.files
    assert first.name == "session-000007-20260509T041320Z.ch10"
    assert second.name.endswith("-part2.ch10")
    recorded = replay(first)
    assert content(recorded) == content(flown)
    # rebased to the whole second: 0.25 s into the file's first second
    assert all(abs(a.t_ns - (b.t_ns + 250_000_000)) <= 50
               for a, b in zip(recorded, flown, strict=True))
    assert str(recorded[0].extra["time"]).startswith("2026-05-09T04:13:20.25")
    assert content(replay(second)) == content(flown[:10])
