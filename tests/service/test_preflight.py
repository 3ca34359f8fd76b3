"""`mapr run --check` (and `mapr run`) refuse configs the daemon could not work with here:
one line naming the config file and line, exit 78, before anything starts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.errors import ConfigError
from mapr_daemon.service.config import load_config
from mapr_daemon.service.preflight import load_checked

ROOT = Path(__file__).resolve().parents[2]


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "mapr.yaml"
    path.write_text(text)
    return path


def problem(tmp_path: Path, text: str) -> str:
    config = write(tmp_path, text)
    with pytest.raises(ConfigError) as caught:
        load_checked(config)
    return str(caught.value).replace(str(config), "CONFIG").replace(str(tmp_path), "TMP")


@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf"])
def test_a_non_finite_interval_is_refused(tmp_path: Path, value: str) -> None:
    text = f"log_level: info\ncatalog:\n  stats_interval_s: {value}\n"
    assert problem(tmp_path, text).startswith(
        "CONFIG:3: catalog.stats_interval_s: expected a finite number")
    with pytest.raises(ConfigError):   # a number nobody could mean, whatever the machine
        load_config(write(tmp_path, text))


def test_a_missing_recording_to_replay_is_refused(tmp_path: Path) -> None:
    text = f"backend:\n  name: chapter10\n  options:\n    speed: 1.0\n" \
           f"    path: {tmp_path / 'flight.c10'}\n"
    assert problem(tmp_path, text) == \
        "CONFIG:5: backend.options.path: TMP/flight.c10: no such file"


def test_a_capture_path_that_is_a_directory_is_refused(tmp_path: Path) -> None:
    text = f"backend:\n  name: capture\n  options: {{path: {tmp_path}}}\n"
    assert problem(tmp_path, text) == "CONFIG:3: backend.options.path: TMP: not a regular file"


def test_a_file_backend_without_a_path_is_refused(tmp_path: Path) -> None:
    assert problem(tmp_path, "backend:\n  name: chapter10\n") == \
        "CONFIG:2: backend.options.path: the chapter10 backend needs the file to read"


def test_a_negative_replay_speed_is_refused(tmp_path: Path) -> None:
    recording = tmp_path / "flight.c10"
    recording.write_bytes(b"")
    text = f"backend:\n  name: chapter10\n  options:\n    path: {recording}\n    speed: -1\n"
    assert problem(tmp_path, text) == \
        "CONFIG:5: backend.options.speed: expected a finite number >= 0, got -1"


def test_a_recording_path_that_is_a_file_is_refused(tmp_path: Path) -> None:
    taken = tmp_path / "flights"
    taken.write_text("not a directory")
    assert problem(tmp_path, f"record:\n  path: {taken}\n") == (
        "CONFIG:2: record.path: TMP/flights: exists and is not a directory (recordings are "
        "files in a directory)")


def test_a_recording_path_under_a_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    assert problem(tmp_path, f"record:\n  path: {tmp_path / 'file' / 'flights'}\n") == (
        "CONFIG:2: record.path: TMP/file/flights: cannot be created: TMP/file is not a "
        "directory")


def test_a_catalog_path_that_is_a_directory_is_refused(tmp_path: Path) -> None:
    assert problem(tmp_path, f"catalog:\n  path: {tmp_path}\n") == \
        "CONFIG:2: catalog.path: TMP: is a directory (the catalog is a file)"


def test_a_catalog_under_a_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    assert problem(tmp_path, f"catalog:\n  path: {tmp_path / 'file' / 'c.db'}\n") == \
        "CONFIG:2: catalog.path: TMP/file/c.db: TMP/file: exists and is not a directory"


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs a Linux /proc")
def test_output_paths_where_nothing_can_be_written_are_refused(tmp_path: Path) -> None:
    """Tried, not read off permission bits: /proc takes no file, even from root."""
    assert problem(tmp_path, "record:\n  path: /proc/mapr-flights\n").startswith(
        "CONFIG:2: record.path: /proc/mapr-flights: cannot be created in /proc: ")
    assert problem(tmp_path, "catalog:\n  path: /proc/self/mapr.db\n").startswith(
        "CONFIG:2: catalog.path: /proc/self/mapr.db: /proc/self: directory not writable: ")


@pytest.mark.parametrize(("key", "field"), [("icd", "icd"),
                                            ("reasoner:\n  dictionary", "reasoner.dictionary")])
def test_unreadable_inputs_are_refused_with_their_line(tmp_path: Path, key: str,
                                                       field: str) -> None:
    text = f"log_level: info\n{key}: {tmp_path / 'gone.yaml'}\n"
    line = 2 if "\n" not in key else 3
    assert problem(tmp_path, text).startswith(
        f"CONFIG:{line}: {field}: TMP/gone.yaml: no such file")
    assert problem(tmp_path, f"log_level: info\n{key}: {tmp_path}\n").startswith(
        f"CONFIG:{line}: {field}: TMP: not a regular file")


def test_a_missing_actuator_file_is_refused_with_its_line(tmp_path: Path) -> None:
    text = f"assets:\n  - name: EMA1\n    rt: 5\n  - name: EMA2\n    rt: 6\n" \
           f"    actuator: {tmp_path / 'gone.yaml'}\n"
    assert problem(tmp_path, text) == \
        "CONFIG:6: assets[1].actuator: TMP/gone.yaml: no such file"


def test_backend_options_it_does_not_take_are_refused(tmp_path: Path) -> None:
    text = "backend:\n  name: serial\n  options:\n    port: /dev/ttyUSB0\n    baud: 9600\n"
    message = problem(tmp_path, text)
    assert message.startswith("CONFIG:5: backend.options.baud: backend 'serial': unknown "
                              "option baud (its options: ")
    assert "idle_s" in message


@pytest.mark.parametrize(("value", "why"), [(".nan", "expected a finite number, got nan"),
                                            ("-.inf", "expected a finite number, got -inf"),
                                            ("0", "a time must be > 0 seconds, got 0"),
                                            ("-0.5", "a time must be > 0 seconds, got -0.5")])
def test_backend_time_options_must_be_finite_and_positive(tmp_path: Path, value: str,
                                                          why: str) -> None:
    text = f"backend:\n  name: serial\n  options:\n    port: /dev/ttyUSB0\n" \
           f"    idle_s: {value}\n"
    assert problem(tmp_path, text) == f"CONFIG:5: backend.options.idle_s: {why}"


def test_usable_paths_pass(tmp_path: Path) -> None:
    recording = tmp_path / "flight.c10"
    recording.write_bytes(b"")
    config = write(tmp_path, f"backend:\n  name: chapter10\n  options: {{path: {recording}}}\n"
                             f"record:\n  path: {tmp_path / 'new' / 'flights'}\n"
                             f"catalog:\n  path: {tmp_path / 'catalog.db'}\n")
    assert load_checked(config).record.path == str(tmp_path / "new" / "flights")


def test_replay_reads_a_config_whose_backend_file_is_elsewhere(tmp_path: Path) -> None:
    # `mapr replay` takes its recording from the command line, not from backend.options
    config = write(tmp_path, f"backend:\n  name: chapter10\n  options: {{path: "
                             f"{tmp_path / 'gone.c10'}}}\n")
    assert load_config(config).backend.name == "chapter10"


@pytest.mark.parametrize("check", [True, False])
def test_run_exits_78_with_one_line(tmp_path: Path, check: bool) -> None:
    config = write(tmp_path, f"backend:\n  name: chapter10\n  options:\n"
                             f"    path: {tmp_path / 'flight.c10'}\n"
                             f"catalog:\n  path: {tmp_path / 'catalog.db'}\n")
    argv = [sys.executable, "-m", "mapr_daemon.cli.main", "run", "--config", str(config)]
    done = subprocess.run([*argv, "--check"] if check else argv, cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == exitcodes.CONFIG == 78
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1
    assert f"{config}:4: backend.options.path: {tmp_path / 'flight.c10'}: no such file" \
        in lines[0]
    assert not (tmp_path / "catalog.db").exists()   # nothing started


def test_a_backend_option_it_does_not_take_is_refused_on_its_line(tmp_path: Path) -> None:
    text = "backend:\n  name: serial\n  options:\n    port: /dev/ttyUSB0\n    baud: 9600\n"
    line = problem(tmp_path, text)
    assert line.startswith("CONFIG:5: backend.options.baud: backend 'serial': unknown option "
                           "baud (its options: ")
    assert "port" in line
