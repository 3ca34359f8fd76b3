"""The demo's pre-built fault dictionaries and prognostic models (``mapr_daemon/testbed/models/``)
match the code that would build them, load as what they claim to be, and stay small; the key
follows the builds' imports and nothing else; a fresh install's demo builds nothing, and its
successive runs are successive flights."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.testbed import demo_models

ROOT = Path(__file__).resolve().parents[2]
REBUILD = "python3 -m mapr_daemon.testbed.demo_models"


def test_the_shipped_pairs_were_built_by_this_code() -> None:
    stale = demo_models.stale()
    assert not stale, (f"the demo's pre-built models no longer match the code: {stale}; "
                       f"rebuild them with `{REBUILD}` and commit mapr_daemon/testbed/models/")


def test_the_shipped_pairs_load_as_the_stock_actuators_at_their_rates() -> None:
    from mapr_daemon.ema.params import load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

    manifest = demo_models.read_manifest()["pairs"]
    assert sorted(manifest) == sorted(s.stem for s in demo_models.STOCK)
    for stock in demo_models.STOCK:
        entry = manifest[stock.stem]
        name = load_actuator(stock.path).name
        d = Dictionary.load(demo_models.SHIPPED_DIR / entry["dictionary"])
        assert (d.actuator, d.sample_rate_hz) == (name, stock.sample_rate_hz)
        model = PrognosticModel.load(demo_models.SHIPPED_DIR / entry["prognosis"])
        assert model.actuator == name and model.kinds


def test_the_shipped_files_are_small() -> None:
    total = sum(p.stat().st_size for p in demo_models.SHIPPED_DIR.iterdir())
    assert total < 5_000_000, f"{total / 1e6:.1f} MB in {demo_models.SHIPPED_DIR}"


def test_the_demo_flies_the_stock_types() -> None:
    import argparse

    from mapr_daemon.testbed.cli_demo import emas

    none = argparse.Namespace(dictionary=None, prognosis=None, elevator_dictionary=None,
                              elevator_prognosis=None)
    flown = {(e.actuator.name, e.params.sensors.sample_rate_hz) for e in emas(none)}
    assert flown == {(s.actuator, s.sample_rate_hz) for s in demo_models.STOCK}


def test_the_key_covers_the_builds_and_not_the_front_ends() -> None:
    sources = {p.relative_to(ROOT).as_posix() for p in demo_models.build_sources()}
    for needed in ("mapr_daemon/ema/plant.py", "mapr_daemon/ema/bit.py",
                   "mapr_daemon/reasoner/training/dictionary_build.py",
                   "mapr_daemon/reasoner/training/prognosis_build.py",
                   "mapr_daemon/reasoner/diagnosis/dictionary.py", "drivers/jit.py"):
        assert needed in sources
    assert not any(s.startswith(("mapr_daemon/testbed/", "mapr_daemon/cli/",
                                 "mapr_daemon/catalog/")) for s in sources), sources
    spec, stock = demo_models.demo_spec_path(), demo_models.STOCK[0]
    digests = demo_models.source_digests()
    key = demo_models.models_key(spec, stock.path, stock.sample_rate_hz, digests)
    assert key == demo_models.models_key(spec, stock.path, stock.sample_rate_hz, digests)
    touched = {**digests, "mapr_daemon/ema/plant.py": "0" * 16}
    assert demo_models.models_key(spec, stock.path, stock.sample_rate_hz, touched) != key
    assert demo_models.models_key(spec, stock.path, 1000.0, digests) != key


def test_the_import_closure_follows_local_and_relative_imports(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pkg = tmp_path / "mapr_daemon"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from . import helper\n")
    (pkg / "sub" / "helper.py").write_text("import numpy\n")
    (pkg / "sub" / "entry.py").write_text(
        "def f():\n    from ..late import g\n    return g\n")
    (pkg / "late.py").write_text("from mapr_daemon.sub.helper import *\n")
    (pkg / "unused.py").write_text("")
    monkeypatch.setattr(demo_models, "ROOT", tmp_path)
    found = {p.relative_to(tmp_path).as_posix()
             for p in demo_models.build_sources(("mapr_daemon.sub.entry",))}
    assert found == {"mapr_daemon/__init__.py", "mapr_daemon/sub/__init__.py",
                     "mapr_daemon/sub/helper.py", "mapr_daemon/sub/entry.py",
                     "mapr_daemon/late.py"}


def mapr(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, **env})


def test_a_fresh_install_builds_nothing_and_each_run_is_the_next_flight(tmp_path: Path) -> None:
    from mapr_daemon.catalog import CatalogReader

    if demo_models.stale():
        pytest.skip("the shipped models are stale (test_the_shipped_pairs_were_built_by_this_"
                    "code says how to rebuild them): this run would build them")
    cache = tmp_path / "cache"
    for _ in range(2):
        result = mapr("demo", "--word-level", "--show", "0", env={"MAPR_CACHE": str(cache)})
        assert result.returncode == 0, result.stderr
        assert "Building" not in result.stderr, result.stderr
        assert "ANOMALY esr" in result.stdout, result.stdout
    assert sorted(p.name for p in cache.iterdir() if p.suffix == ".npz") == []
    with CatalogReader(cache / "demo-catalog.sqlite") as reader:
        flights = sorted({(b.asset, b.flight) for b in reader.bits()})
    assert flights == [("EMA1", 1), ("EMA1", 2), ("EMA2", 1), ("EMA2", 2)]


def test_the_demo_spec_is_the_full_spec_but_its_grid() -> None:
    """The demo's spec differs from the shipped one only in its pressures and severities (a
    key added to the full spec must be added to the demo's)."""
    import yaml

    from mapr_daemon.cli.commands.dictionary import default_spec_path

    full = yaml.safe_load(default_spec_path().read_text(encoding="utf-8"))
    demo = yaml.safe_load(demo_models.demo_spec_path().read_text(encoding="utf-8"))
    grid = {"pressures_pa", "severities"}
    assert {k: v for k, v in demo.items() if k not in grid} == \
        {k: v for k, v in full.items() if k not in grid}
    assert set(demo) == set(full)
