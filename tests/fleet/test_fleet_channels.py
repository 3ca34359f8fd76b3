"""``mapr fleet --c10-channel``: every task reads only the 1553 channels asked for, and a
recording without one of them is a failed recording whose error says what it holds.

Each recording of the small archive (tests/fleet/conftest.py: the actuator's bus on channel 1)
gets a second bus appended on channel 7, written with the project's packet writer: traffic of
an RT the configuration does not know (RT 20), so the message counts tell which channels a
task read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.recording_packets import ms1553_packet
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.cli.main import build_parser
from mapr_daemon.fleet.archive import discover
from mapr_daemon.fleet.runner import FleetRun, task_key
from mapr_daemon.fleet.task import Job, TaskResult, process_recording, with_channels
from tests.fleet.test_fleet_run import configs

EXTRA = 7
"""The appended bus's channel ID."""
EXTRA_MESSAGES = 90


def _add_bus(path: Path) -> None:
    """Append :data:`EXTRA_MESSAGES` BC->RT messages to RT 20 SA 1 on channel :data:`EXTRA`,
    in two packets."""
    records = [MonitorRecord(t_ns=i * 10_000_000, bus="A", format=TransferFormat.BC_RT,
                             command=20 << 11 | 1 << 5 | 2, data=(i, 0), status=(20 << 11,),
                             gaps_ns=(8000,), end_ns=i * 10_000_000 + 4 * 20_000)
               for i in range(EXTRA_MESSAGES)]
    half = EXTRA_MESSAGES // 2
    with path.open("ab") as out:
        out.write(ms1553_packet(EXTRA, 0, records[:half]) + ms1553_packet(EXTRA, 1, records[half:]))


def _messages(path: Path, channels: set[int] | None) -> int:
    reader = Chapter10Reader(path, channels=channels, arinc429=False)
    try:
        return sum(len(b.ms1553) for b in reader.batches(8192) if b.ms1553 is not None)
    finally:
        reader.close()


def test_fleet_takes_c10_channel_repeated() -> None:
    args = build_parser().parse_args(["fleet", "archive", "--c10-channel", "3",
                                      "--c10-channel", "4"])
    assert args.c10_channels == [3, 4]


def test_the_channel_pick_is_part_of_the_digest_and_the_task_key(
        fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    fleet = configs(fleet_dictionary)
    recording = discover([fleet_archive])[0][0]
    with CatalogWriter(tmp_path / "c.db") as catalog:
        every = FleetRun(None, catalog, fleet)  # type: ignore[arg-type]
        picked = FleetRun(None, catalog, fleet, channels=[3, 1, 3])  # type: ignore[arg-type]
        other = FleetRun(None, catalog, fleet, channels=[1])  # type: ignore[arg-type]
    # every channel read: the config's content digest itself (catalogs stored before stay current)
    assert every.digest("N101") == fleet.digest("N101") == with_channels(fleet.digest(), None)
    assert picked.digest("N101") == with_channels(fleet.digest(), {1, 3})   # order, repeats aside
    assert len({every.digest("N101"), picked.digest("N101"), other.digest("N101")}) == 3
    assert len({task_key(recording, r.digest(recording.tail))
                for r in (every, picked, other)}) == 3


def test_each_worker_reads_only_the_channels_asked_for(
        dask_client: Any, fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    recordings, _ = discover([fleet_archive])
    own = {}
    for recording in recordings:
        path = Path(recording.path)
        own[recording.path] = _messages(path, None)
        _add_bus(path)
        assert _messages(path, None) == own[recording.path] + EXTRA_MESSAGES
    results: list[TaskResult] = []
    with CatalogWriter(tmp_path / "fleet.db") as writer:
        writer.open_session(backend="fleet", config_hash="test")
        summary = FleetRun(dask_client, writer, configs(fleet_dictionary), results.append,
                           channels=[1]).run(recordings)
    assert summary.stored == 4 and not summary.failed
    assert {r.recording.path: r.messages for r in results} == own
    assert {r.config_digest for r in results} == {with_channels(
        configs(fleet_dictionary).digest(), [1])}
    assert summary.bits == 4   # the actuator's bus, read whole: every flight's BIT

    with CatalogWriter(tmp_path / "other.db") as writer:
        writer.open_session(backend="fleet", config_hash="test")
        results.clear()
        summary = FleetRun(dask_client, writer, configs(fleet_dictionary), results.append,
                           channels=[EXTRA]).run(recordings[:1])
    assert summary.stored == 1 and summary.bits == 0
    assert results[0].messages == EXTRA_MESSAGES


def test_a_recording_without_an_asked_channel_says_what_it_holds(
        fleet_archive: Path, fleet_dictionary: Path) -> None:
    recording = discover([fleet_archive])[0][0]
    fleet = configs(fleet_dictionary)
    result = process_recording(Job(recording, fleet.default, fleet.digest(),
                                   frozenset({1, 9})))
    assert not result.ok and result.messages == 0
    assert result.error is not None and result.error.startswith(
        "channel 9 not in the recording (it holds: "), result.error
    assert "1553 channel 1" in result.error
