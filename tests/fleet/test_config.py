"""The fleet config: each tail's actuator set once, errors naming file:line, exit 78; and
the progress lines a log gets."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.errors import ConfigError
from mapr_daemon.fleet.config import load_fleet_config
from mapr_daemon.fleet.progress import FleetProgress

ROOT = Path(__file__).resolve().parents[2]


def test_default_and_per_tail_sections(tmp_path: Path) -> None:
    path = tmp_path / "fleet.yaml"
    path.write_text("default:\n  assets: [{name: EMA1, rt: 5}]\n"
                    "  reasoner: {dictionary: d.npz}\n"
                    "tails:\n  N102:\n    assets: [{name: AIL, rt: 5, actuator: "
                    f"{ROOT / 'configs/actuators/elevator-uav.yaml'}}}]\n"
                    "    reasoner: {dictionary: e.npz, threshold: 9}\n")
    fleet = load_fleet_config(path)
    assert fleet.for_tail("N101").assets[0].name == "EMA1"
    assert fleet.for_tail("N101").reasoner.dictionary == str(tmp_path / "d.npz")
    other = fleet.for_tail("N102")
    assert other.assets[0].name == "AIL" and other.reasoner.threshold == 9.0
    assert other.assets[0].actuator.endswith("elevator-uav.yaml")


def test_errors_name_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "fleet.yaml"
    path.write_text("default:\n  reasoner: {dictionary: d.npz}\ntails:\n  N7:\n"
                    "    assets: [{name: EMA1, rt: 44}]\n")
    with pytest.raises(ConfigError) as caught:
        load_fleet_config(path)
    assert str(caught.value).startswith(f"{path}:5:") and "rt" in str(caught.value)
    path.write_text("defaults: {}\n")
    with pytest.raises(ConfigError, match=r":1: defaults: unknown key"):
        load_fleet_config(path)
    code = main(["fleet", str(tmp_path), "--config", str(path), "--catalog",
                 str(tmp_path / "c.db")])
    assert code == exitcodes.CONFIG and "unknown key" in capsys.readouterr().err
    assert not (tmp_path / "c.db").exists()   # nothing started


def test_no_dictionary_is_a_config_error(tmp_path: Path) -> None:
    assert main(["fleet", str(tmp_path), "--catalog", str(tmp_path / "c.db")]) == \
        exitcodes.CONFIG


def test_progress_in_a_log_is_a_line_per_tenth() -> None:
    out = io.StringIO()
    progress = FleetProgress(out, 20, 30.0, tty=False)
    for _ in range(20):
        progress.add(1.5, ok=True)
    progress.show(final=True)
    lines = out.getvalue().splitlines()
    assert len(lines) == 10
    assert lines[-1].startswith("mapr fleet: 100%  20/20 recordings  30.0/30.0 flight h")
    tty = io.StringIO()
    bar = FleetProgress(tty, 2, 3.0, tty=True)
    bar.add(1.5, ok=False)
    bar.show(final=True)
    assert tty.getvalue().startswith("\r[##########----------]  50%  1/2 recordings")
    assert "1 failed" in tty.getvalue() and tty.getvalue().endswith("\n")
    assert "0.0/3.0 flight h" in tty.getvalue()   # a failed recording's hours do not count


def test_the_digest_is_of_the_files_content_not_their_spelling(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same dictionary named relative, absolute or through ``..`` is one configuration;
    a dictionary rebuilt in place is another; every path a worker opens is absolute."""
    import dataclasses

    from mapr_daemon.fleet.config import FleetConfig
    from mapr_daemon.pipeline.settings import ReasonerConfig
    from mapr_daemon.service.config import Config

    (tmp_path / "sub").mkdir()
    (tmp_path / "d.npz").write_bytes(b"dictionary one")
    monkeypatch.chdir(tmp_path / "sub")

    def fleet(dictionary: str, icd: str | None = None) -> FleetConfig:
        config = Config(reasoner=ReasonerConfig(dictionary=dictionary))
        if icd is not None:
            config = dataclasses.replace(config, icd=icd)
        return FleetConfig(config).absolute()

    spellings = [fleet("../d.npz"), fleet(str(tmp_path / "d.npz")),
                 fleet(str(tmp_path / "sub" / ".." / "d.npz"))]
    assert len({f.digest() for f in spellings}) == 1
    assert all(f.default.reasoner.dictionary == str(tmp_path / "d.npz") for f in spellings)
    assert all(Path(a.actuator).is_absolute() for f in spellings for a in f.default.assets)
    # the shipped ICD copied elsewhere and named relative: the same content, the same digest
    (tmp_path / "icd.yaml").write_bytes(Path(Config().icd).read_bytes())
    assert fleet("../d.npz", "../icd.yaml").digest() == spellings[0].digest()
    (tmp_path / "d.npz").write_bytes(b"dictionary two")
    assert fleet("../d.npz").digest() != spellings[0].digest()
