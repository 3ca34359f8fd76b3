"""Every command that reads a recording picks its buses and reads a stream; statistics count
what the filters keep, one channel (one bus) at a time.

The recording is eight 1553 buses written with the project's Chapter 10 packet writer
(:mod:`tests.support.multibus`): on each, at 450 Hz, RT 5 T SA 2 (RT->BC), RT 6 R SA 1
(BC->RT) and the RT-RT transfer ``05-04<06-03``. Streams go to stdin through a pipe.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.support.cli_run import mapr
from tests.support.multibus import RATE_HZ, SECONDS, write_recording

ROOT = Path(__file__).resolve().parents[2]
CHANNELS = list(range(1, 9))
READERS = [["decode"], ["monitor"], ["replay"], ["icd", "discover"], ["fleet"]]
"""The commands that read a Chapter 10 recording."""




def json_lines(text: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in text.splitlines()]


@pytest.fixture(scope="module")
def eight_buses(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_recording(tmp_path_factory.mktemp("c10") / "eight.c10", CHANNELS)


@pytest.mark.parametrize("command", READERS, ids=" ".join)
def test_every_reader_of_a_recording_takes_c10_channel(command: list[str]) -> None:
    from mapr_daemon.cli.main import build_parser

    parser = build_parser()
    args = parser.parse_args([*command, "x.c10", "--c10-channel", "3", "--c10-channel", "4"]
                             if command != ["monitor"] else
                             ["monitor", "--backend", "chapter10", "--c10-channel", "3",
                              "--c10-channel", "4"])
    assert args.c10_channels == [3, 4]


def test_replay_reads_a_stream_on_stdin(eight_buses: Path, tmp_path: Path) -> None:
    run = mapr("replay", "-", "--c10-channel", "2", "--c10-channel", "7", "--catalog",
               str(tmp_path / "c.sqlite"), stdin=eight_buses.read_bytes())
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(f"stdin: replay complete: {2 * 3 * RATE_HZ * SECONDS} "
                                 "messages")


def test_replay_of_an_absent_channel_names_stdin_and_what_it_holds(eight_buses: Path,
                                                                   tmp_path: Path) -> None:
    run = mapr("replay", "-", "--c10-channel", "9", "--catalog", str(tmp_path / "c.sqlite"),
               stdin=eight_buses.read_bytes())
    assert run.returncode == 65
    assert run.stderr == ("mapr replay: stdin: channel 9 not in the recording (it holds: "
                          "TMATS channel 0; time channel 100; 1553 channels "
                          "1, 2, 3, 4, 5, 6, 7, 8)\n")


@pytest.mark.parametrize("command", [["replay"], ["icd", "discover"]], ids=" ".join)
def test_a_stream_that_is_not_a_recording_names_stdin(command: list[str],
                                                      tmp_path: Path) -> None:
    run = mapr(*command, "-", "--c10-channel", "1", stdin=b"not a recording at all\n" * 8)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "stdin" in run.stderr


def test_monitor_picks_channels_of_a_recording(eight_buses: Path) -> None:
    run = mapr("monitor", "--backend", "chapter10", "-O", f"path={eight_buses}", "--json",
               "--c10-channel", "4")
    assert run.returncode == 0, run.stderr
    assert {line["channel"] for line in json_lines(run.stdout)} == {4}
    for wrong in (["--backend", "loopback"],
                  ["--backend", "chapter10", "-O", f"path={eight_buses}", "-O", "channels=3"]):
        refused = mapr("monitor", *wrong, "--c10-channel", "4")
        assert refused.returncode == 2 and refused.stderr.count("\n") == 1
        assert "--c10-channel" in refused.stderr


def test_monitor_stats_count_what_the_filters_keep_per_channel(eight_buses: Path) -> None:
    run = mapr("monitor", "--backend", "chapter10", "-O", f"path={eight_buses}", "--json",
               "--stats", "--rt", "6", "--tr", "T", "--c10-channel", "2",
               "--c10-channel", "3")
    assert run.returncode == 0, run.stderr
    lines = json_lines(run.stdout)
    shown = [line for line in lines if "kind" not in line]
    assert len(shown) == 2 * RATE_HZ * SECONDS   # RT 6 transmits in the RT-RT transfers only
    rows = [line for line in lines if line.get("kind") == "rtsa"]
    assert sorted((r["channel"], r["rt"], r["tr"], r["sa"], r["messages"]) for r in rows) == [
        (c, 6, "T", 3, RATE_HZ * SECONDS) for c in (2, 3)]
    for row in rows:   # one bus's rate, not the two channels' together
        assert row["rate_hz"] == pytest.approx(RATE_HZ, rel=0.01)
    loads = [line for line in lines if line.get("kind") == "bus_load"]
    assert {(load["channel"], load["bus"]) for load in loads} == {(2, "B"), (3, "B")}
    # the per-bus totals (on stderr with --json) count the shown messages, per channel
    assert run.stderr.count("channel 2 (1553)") == 1
    assert f"B          {RATE_HZ * SECONDS}" in run.stderr


def test_monitor_stats_text_has_a_table_per_channel(eight_buses: Path) -> None:
    run = mapr("monitor", "--backend", "chapter10", "-O", f"path={eight_buses}", "--stats",
               "--rt", "5", "--sa", "2", "--c10-channel", "2", "--c10-channel", "6")
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("\n") > 2 * RATE_HZ * SECONDS
    tail = run.stdout.split("channel 2 (1553)", 1)[1]
    assert tail.count("channel 6 (1553)") == 1 and "channel 3" not in tail
    assert tail.count("RT05 T SA02") == 2 and "RT06" not in tail and "RT05 R" not in tail
    assert tail.count(f"A          {RATE_HZ * SECONDS}") == 2   # each bus's shown messages


def test_filtered_decode_stats_are_per_channel(eight_buses: Path) -> None:
    run = mapr("decode", str(eight_buses), "--stats", "json", "--rt", "5", "--tr", "R")
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""   # no warning: the channels are not merged any more
    rows = [line for line in json_lines(run.stdout) if line["kind"] == "rtsa"]
    assert sorted((r["channel"], r["rt"], r["tr"], r["sa"]) for r in rows) == [
        (c, 5, "R", 4) for c in CHANNELS]
    assert all(r["messages"] == RATE_HZ * SECONDS for r in rows)
    assert all(r["rate_hz"] == pytest.approx(RATE_HZ, rel=0.01) for r in rows)
