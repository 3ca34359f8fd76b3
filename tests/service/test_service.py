"""The daemon as systemd runs it: notify protocol, SIGTERM, SIGHUP, config errors, gaps."""

from __future__ import annotations

import shutil
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # the fixture's class; pytest loads conftest itself
    from tests.daemon.conftest import Daemon

ROOT = Path(__file__).resolve().parents[2]
STOP_TIMEOUT_S = float(next(
    line.split("=", 1)[1].rstrip("s") for line in (ROOT / "systemd" / "mapr.service").read_text()
    .splitlines() if line.startswith("TimeoutStopSec=")))
"""How long systemd gives the daemon to stop before it kills it (the unit's TimeoutStopSec)."""
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"

CAPTURE = ROOT / "tests" / "data" / "codec" / "ema-cruise-20ms.sr"


def monitor_only(tmp: Path, extra: str = "") -> str:
    """A config: the loopback testbed in real time, no dictionary, fast status and stats."""
    return (f"icd: {ICD}\n"
            f"catalog: {{path: {tmp / 'catalog.sqlite'}, stats_interval_s: 0.3}}\n"
            "status_interval_s: 0.2\n" + extra)


def rows(path: Path, sql: str) -> list[tuple[object, ...]]:
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as conn:
        return conn.execute(sql).fetchall()


def test_ready_status_watchdog_then_sigterm_closes_the_session(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    daemon = start_daemon(monitor_only(tmp_path), watchdog_usec=200_000)
    daemon.wait_notify("READY=1")
    daemon.wait_notify("WATCHDOG=1", count=3, timeout=10)
    daemon.wait_for(lambda: any("msg/s" in s and "errors" in s and "events" in s
                                for s in daemon.lines("STATUS=")), 10, "STATUS")
    time.sleep(0.5)
    code, took = daemon.terminate()
    assert code == 0, daemon.log
    assert took < STOP_TIMEOUT_S, "systemd would have killed it (TimeoutStopSec)"
    assert "<6>ready: backend open, first message decoded" in daemon.log
    daemon.drain()
    assert daemon.lines("STOPPING=1")
    # READY only after the first decoded message: the first STATUS with READY counts some
    ready = next(m for m in daemon.messages if "READY=1" in m)
    assert "monitoring" in ready
    catalog = tmp_path / "catalog.sqlite"
    (stopped, reason, backend, digest, version), = rows(
        catalog, "SELECT stopped_ns, stop_reason, backend, config_hash, software_version "
                 "FROM sessions")
    assert stopped is not None and reason == "SIGTERM" and backend == "testbed"
    assert digest and version
    stats = rows(catalog, "SELECT bus, messages, load_percent FROM bus_stats")
    assert stats and all(int(str(m)) > 0 for _, m, _ in stats)
    per_key = rows(catalog, "SELECT rt, tr, sa, sum(messages), sum(responses) FROM rt_stats "
                            "WHERE mode_code IS NULL GROUP BY rt, tr, sa")
    fast = [(n, answered) for rt, tr, sa, n, answered in per_key if (rt, tr, sa) == (5, "T", 10)]
    assert fast and 0 < int(str(fast[0][1])) <= int(str(fast[0][0]))   # the EMA's fast block


def test_no_watchdog_without_watchdog_usec(tmp_path: Path,
                                           start_daemon: Callable[..., Daemon]) -> None:
    daemon = start_daemon(monitor_only(tmp_path))
    daemon.wait_notify("READY=1")
    daemon.wait_notify("STATUS=", count=3, timeout=10)
    assert not daemon.lines("WATCHDOG=1")
    assert daemon.terminate()[0] == 0


def test_sighup_reloads_a_valid_config_and_keeps_the_old_on_an_invalid_one(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    import signal
    daemon = start_daemon(monitor_only(tmp_path))
    daemon.wait_notify("READY=1")
    config = tmp_path / "mapr.yaml"
    config.write_text(monitor_only(tmp_path, "log_level: debug\n"), encoding="utf-8")
    daemon.proc.send_signal(signal.SIGHUP)
    daemon.wait_log("<6>reloaded")
    config.write_text(monitor_only(tmp_path, "queue_batches: 0\n"), encoding="utf-8")
    daemon.proc.send_signal(signal.SIGHUP)
    daemon.wait_log("reload failed")
    line = next(x for x in daemon.log.splitlines() if "reload failed" in x)
    assert line.startswith("<3>")
    assert f"{config}:4: queue_batches: must be >= 1" in line
    seen = len(daemon.lines("STATUS="))
    daemon.wait_notify("STATUS=", count=seen + 3, timeout=10)   # still running
    assert daemon.proc.poll() is None
    assert daemon.terminate()[0] == 0


def run_config(tmp_path: Path, text: str) -> subprocess.CompletedProcess[str]:
    config = tmp_path / "bad.yaml"
    config.write_text(text, encoding="utf-8")
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "run", "--config",
                           str(config)], cwd=ROOT, capture_output=True, text=True, timeout=60)


def test_config_error_exits_78_with_file_line_and_field(tmp_path: Path) -> None:
    done = run_config(tmp_path, f"icd: {ICD}\nbackend:\n  name: testbed\n"
                                "  retry_initial_s: fast\n")
    assert done.returncode == 78
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("<3>mapr run: ")
    assert f"{tmp_path / 'bad.yaml'}:4: backend.retry_initial_s: expected float" in lines[0]


def test_icd_error_exits_78(tmp_path: Path) -> None:
    icd = tmp_path / "broken-icd.yaml"
    icd.write_text("name: x\nmessages: [\n", encoding="utf-8")
    done = run_config(tmp_path, f"icd: {icd}\n")
    assert done.returncode == 78
    assert str(icd) in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_unknown_key_and_bad_fault_exit_78(tmp_path: Path) -> None:
    done = run_config(tmp_path, f"icd: {ICD}\ntestbed:\n  flight: bit\n")
    assert done.returncode == 78 and ":3: testbed.flight: unknown key" in done.stderr
    done = run_config(tmp_path, f"icd: {ICD}\ntestbed: {{fault: 'warp@2'}}\n")
    assert done.returncode == 78 and "warp" in done.stderr


def test_watchdog_goes_on_while_a_backend_is_retried(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    """A card unplugged for longer than the 5 s liveness window must not starve the
    watchdog (systemd would kill a daemon that is doing its job: retrying). The stand-in for
    the unplugged card is a capture file that exists but holds no capture (a missing file is
    a configuration error, refused at start)."""
    (tmp_path / "no.sr").write_bytes(b"")
    # the retry is far off (120 s): every wait below ends long before it, however loaded the
    # host, so the pings counted are pings sent while retrying
    daemon = start_daemon(
        f"icd: {ICD}\nbackend:\n  name: capture\n  options: {{path: {tmp_path / 'no.sr'}}}\n"
        "  retry_initial_s: 120\n  retry_max_s: 120\n"
        f"catalog: {{path: {tmp_path / 'catalog.sqlite'}}}\n", watchdog_usec=400_000)
    daemon.wait_log("retrying in 120.0 s")
    time.sleep(5.5)   # at least past the liveness window (sleep only ever runs longer)
    daemon.drain()
    before = len(daemon.lines("WATCHDOG=1"))
    daemon.wait_notify("WATCHDOG=1", count=before + 3, timeout=30)
    assert "retrying" not in daemon.log.split("retrying in 120.0 s", 1)[1]
    assert daemon.terminate()[0] == 0


def test_backend_failure_is_retried_and_recorded_as_a_gap(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    capture = tmp_path / "bus.sr"
    capture.write_bytes(b"")   # there, but no capture yet: the card's stand-in, unplugged
    daemon = start_daemon(
        f"icd: {ICD}\nbackend:\n  name: capture\n  options: {{path: {capture}}}\n"
        "  retry_initial_s: 0.05\n  retry_max_s: 0.2\n"
        f"catalog: {{path: {tmp_path / 'catalog.sqlite'}, stats_interval_s: 0.3}}\n"
        "status_interval_s: 0.2\n")
    daemon.wait_log("monitoring gap: backend: CaptureFormatError")
    daemon.wait_for(lambda: daemon.log.count("retrying in") >= 4, 10, "retries")
    assert daemon.proc.poll() is None
    assert any("backend down" in s for s in daemon.lines("STATUS="))
    assert not daemon.lines("READY=1")
    shutil.copy(CAPTURE, capture)              # the card is back
    daemon.wait_notify("READY=1")
    daemon.wait_log("backend back after a gap")
    assert daemon.terminate()[0] == 0
    gaps = rows(tmp_path / "catalog.sqlite", "SELECT start_ns, end_ns, reason FROM gaps")
    assert len(gaps) == 1
    start, end, reason = gaps[0]
    assert end is not None and int(str(end)) > int(str(start))
    assert "CaptureFormatError" in str(reason)


def test_signals_wake_an_idle_daemon_at_once(tmp_path: Path,
                                             start_daemon: Callable[..., Daemon]) -> None:
    """The loop sleeps until its next timer (here 60 s away) unless a signal or bus work
    wakes it: SIGHUP and SIGTERM must be handled long before that (the self-pipe)."""
    import signal
    daemon = start_daemon(
        f"icd: {ICD}\ntestbed: {{realtime: false, duration_s: 0.3}}\n"
        f"catalog: {{path: {tmp_path / 'catalog.sqlite'}, stats_interval_s: 60}}\n"
        "status_interval_s: 60\n")
    daemon.wait_log("stream ended", timeout=60)   # idle from here: no work, timers far off
    time.sleep(0.3)
    daemon.proc.send_signal(signal.SIGHUP)
    daemon.wait_log("<6>reloaded", timeout=20)
    code, took = daemon.terminate()
    assert code == 0, daemon.log
    assert took < 20, f"SIGTERM took {took:.1f} s: the loop slept through it"
    assert "stopping (SIGTERM)" in daemon.log
