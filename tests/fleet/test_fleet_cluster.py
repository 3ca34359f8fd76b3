"""``mapr fleet`` on a real cluster: a ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1, started here (random free ports, working directories of their own, torn down by
the fixtures), and the command run as a user would, from another directory, with relative
paths; and the cluster's faults (a scheduler unreachable, malformed, killed mid-run), each
ended in one line, its exit code and a closed session.

No timing assertions: the subprocesses get generous timeouts, and the fault cases end within
the connect timeout (5 s) on an idle machine.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.testbed.fleet import FleetSpec, generate

ROOT = Path(__file__).resolve().parents[2]
DASK = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]
START_S = 120.0
"""How long a cluster may take to come up on a loaded machine."""
RUN_S = 300.0


@dataclass
class Cluster:
    address: str
    scheduler: subprocess.Popen[bytes]
    workers: list[subprocess.Popen[bytes]]


def _env() -> dict[str, str]:
    """MAPR importable from the repository (the scheduler unpickles the tasks too)."""
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _start_cluster(where: Path, workers: int = 2) -> Cluster:
    where.mkdir(parents=True, exist_ok=True)
    address_file = where / "scheduler.json"
    log = (where / "scheduler.log").open("wb")
    scheduler = subprocess.Popen(
        [*DASK, "--host", "127.0.0.1", "--port", "0", "--dashboard-address", "127.0.0.1:0",
         "--scheduler-file", str(address_file), "--no-show"],
        cwd=where, env=_env(), stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    deadline = time.monotonic() + START_S
    while not address_file.exists() or not address_file.read_text().strip():
        if scheduler.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"the scheduler did not start: {(where / 'scheduler.log')}")
        time.sleep(0.2)
    address = json.loads(address_file.read_text())["address"]
    procs = []
    for i in range(workers):
        home = where / f"worker{i}"
        home.mkdir()
        procs.append(subprocess.Popen(
            [*WORKER, address, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1",
             "--local-directory", str(home), "--name", f"w{i}"],
            cwd=home, env=_env(), stdout=(home / "log").open("wb"), stderr=subprocess.STDOUT,
            start_new_session=True))
    cluster = Cluster(address, scheduler, procs)
    from distributed import Client

    with Client(address, timeout="60s") as client:  # type: ignore[no-untyped-call]
        client.wait_for_workers(workers, timeout=START_S)
    return cluster


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """End a process this test started (and its own process group: a worker's nanny)."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _stop_cluster(cluster: Cluster) -> None:
    for proc in cluster.workers:
        _stop(proc)
    _stop(cluster.scheduler)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    started = _start_cluster(tmp_path_factory.mktemp("cluster"))
    yield started
    _stop_cluster(started)


@pytest.fixture
def workdir(tmp_path: Path, fleet_source: Path, fleet_dictionary: Path) -> Path:
    """A user's directory: ``archive/`` and ``d.npz``, named relative from here."""
    shutil.copytree(fleet_source, tmp_path / "archive")
    shutil.copy(fleet_dictionary, tmp_path / "d.npz")
    return tmp_path


def mapr_fleet(workdir: Path, *args: str, timeout: float = RUN_S
               ) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "fleet", *args],
                          cwd=workdir, env=_env(), capture_output=True, text=True,
                          timeout=timeout)


def _sessions(catalog: Path) -> list[tuple[int, int | None, str | None]]:
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT id, stopped_ns, stop_reason FROM sessions").fetchall()


def _recordings(catalog: Path) -> list[tuple[str, str, str]]:
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT path, status, config_digest FROM recordings ORDER BY id"
                            ).fetchall()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def test_relative_paths_on_a_real_cluster(cluster: Cluster, workdir: Path) -> None:
    """The workers run elsewhere: every path they need was made absolute on the client. A
    recording at the archive's root is reported and counted; the digest is the content's."""
    shutil.copy(workdir / "archive" / "N101" / "flight-0001.ch10",
                workdir / "archive" / "stray.ch10")
    run = mapr_fleet(workdir, "archive", "--dictionary", "d.npz", "--catalog", "fleet.db",
                     "--scheduler", cluster.address, "--no-progress")
    assert run.returncode == exitcodes.DATAERR, run.stderr
    assert run.stdout.startswith(
        "fleet: 5 recordings (4 of 2 tails, 1 with no tail and flight in their path): "
        "4 stored, 0 already in the catalog, 1 failed\n"), run.stdout
    assert run.stderr.splitlines() == [
        f"mapr fleet: {workdir / 'archive' / 'stray.ch10'}: tail and flight not in its path "
        f"below the archive {workdir / 'archive'} (see --pattern)"]
    rows = _recordings(workdir / "fleet.db")
    assert [r[1] for r in rows] == ["done"] * 4
    assert all(Path(r[0]).is_absolute() for r in rows)
    assert all(r[0].startswith(str(workdir / "archive" / "N10")) for r in rows)
    assert [r[2] for r in _sessions(workdir / "fleet.db")] == ["fleet run complete"]
    # the same files named another way: the same configuration, nothing to do again
    (workdir / "archive" / "stray.ch10").unlink()
    again = mapr_fleet(workdir, str(workdir / "archive" / "N101" / ".."), "--dictionary",
                       str(workdir / "." / "d.npz"), "--catalog", "fleet.db",
                       "--scheduler", cluster.address, "--no-progress")
    assert again.returncode == exitcodes.OK, again.stderr
    assert "0 stored, 4 already in the catalog, 0 failed" in again.stdout
    assert "with another config" not in again.stdout


def test_an_unreachable_scheduler_is_one_line(workdir: Path) -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    run = mapr_fleet(workdir, "archive", "--dictionary", "d.npz", "--catalog", "fleet.db",
                     "--scheduler", address, timeout=120)
    assert run.returncode == exitcodes.UNAVAILABLE
    assert run.stdout == ""
    (line,) = run.stderr.splitlines()
    assert line.startswith(f"mapr fleet: Dask scheduler {address}: cannot be reached "
                           f"within 5 s")
    assert not (workdir / "fleet.db").exists() or all(
        s[1] is not None for s in _sessions(workdir / "fleet.db"))


@pytest.mark.parametrize("address", ["bogus://x", "tcp://host", "tcp://127.0.0.1:99999",
                                     "inproc://x"])
def test_a_malformed_scheduler_address_is_a_usage_error(workdir: Path, address: str) -> None:
    run = mapr_fleet(workdir, "archive", "--dictionary", "d.npz", "--catalog", "fleet.db",
                     "--scheduler", address, timeout=120)
    assert run.returncode == exitcodes.USAGE
    (line,) = run.stderr.splitlines()
    assert line.startswith(f"mapr fleet: error: --scheduler {address!r}:")
    assert not (workdir / "fleet.db").exists()


@pytest.fixture
def big_archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """40 recordings: more than the client stores before the scheduler is killed."""
    root = tmp_path_factory.mktemp("big")
    generate(root / "archive", FleetSpec(tails=4, flights=10, seed=8, degrading=0.5))
    return root / "archive"


def test_a_scheduler_killed_mid_run(tmp_path: Path, big_archive: Path,
                                    fleet_dictionary: Path) -> None:
    """Killed once the first tenth is stored: one line, exit 69, the session closed as
    ``scheduler lost``, and what was stored is whole (a later run resumes the rest)."""
    own = _start_cluster(tmp_path / "cluster")
    try:
        shutil.copy(fleet_dictionary, tmp_path / "d.npz")
        shutil.copytree(big_archive, tmp_path / "archive")
        run = subprocess.Popen(
            [sys.executable, "-m", "mapr_daemon.cli.main", "fleet", "archive", "--dictionary",
             "d.npz", "--catalog", "fleet.db", "--scheduler", own.address],
            cwd=tmp_path, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True)
        assert run.stderr is not None
        progress = run.stderr.readline()   # the first tenth stored
        assert progress.startswith("mapr fleet:  10%"), progress
        os.killpg(own.scheduler.pid, signal.SIGKILL)
        own.scheduler.wait()
        out, err = run.communicate(timeout=120)
    finally:
        _stop_cluster(own)
    assert run.returncode == exitcodes.UNAVAILABLE, (out, err)
    assert out == ""
    lines = [line for line in err.splitlines() if not line.startswith("mapr fleet: ") or
             "%" not in line]
    assert len(lines) == 1, err
    (line,) = lines
    assert "lost the connection mid-run" in line and "run again to resume" in line
    ((_, stopped, reason),) = _sessions(tmp_path / "fleet.db")
    assert stopped is not None and reason == "scheduler lost"
    rows = _recordings(tmp_path / "fleet.db")
    assert 4 <= len(rows) < 40 and {r[1] for r in rows} == {"done"}


def test_the_dashboard_is_offered_only_where_it_works(capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    """With bokeh (``mapr[dashboard]``) the local cluster's link serves Dask's dashboard;
    without it no link is printed (Dask's page would only say that it needs bokeh)."""
    import argparse
    import urllib.error
    import urllib.request

    from mapr_daemon.cli.commands.fleet import _local_client
    from mapr_daemon.fleet.cluster import close_client, dashboard_available

    client = _local_client(argparse.Namespace(workers=1))
    try:
        line = capsys.readouterr().err.strip()
        assert line.startswith("mapr fleet: local Dask cluster, 1 workers, ")
        if dashboard_available():
            link = line.rsplit(" ", 1)[-1]
            with urllib.request.urlopen(link, timeout=60) as page:
                body = page.read().decode()
            assert "needs bokeh" not in body.lower() and "Dask" in body
        else:
            assert line.endswith("no dashboard (it needs bokeh: pip install 'mapr[dashboard]')")
            with pytest.raises(urllib.error.HTTPError, match="404"):   # no page at all
                urllib.request.urlopen(client.dashboard_link, timeout=60)
    finally:
        close_client(client)
