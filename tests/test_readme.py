"""The README stays true: its Python example runs as shown, and its test command is the one CI
runs (.ci/run)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README, re.S)


@pytest.fixture(scope="module")
def small_dictionary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small dictionary (healthy and ESR) in place of `mapr dictionary build`'s, which takes
    minutes; the example reads it as any other."""
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training import dictionary_build

    spec = DictionarySpec(pressures_pa=(1600.0,), nominal_per_pressure=2,
                          severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr",), shorts=(),
                          opens=(), healthy_runs=48, calibration_runs=12, envelope=True,
                          ground_share=0.0, threshold_margin=1.5)
    path = tmp_path_factory.mktemp("readme-dictionary") / "dictionary.npz"
    dictionary_build.build(load_actuator(default_actuator_path()), spec).save(path)
    return path


def test_the_readme_has_a_python_example() -> None:
    assert python_blocks(), "README.md: no ```python block"


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_the_readme_python_example_runs(index: int, tmp_path: Path,
                                        small_dictionary: Path) -> None:
    """Run as a newcomer runs it: in a fresh interpreter, from a directory holding the
    repository's configs/ and a dictionary.npz, without network."""
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    (tmp_path / "dictionary.npz").symlink_to(small_dictionary)
    script = tmp_path / "example.py"
    script.write_text(python_blocks()[index], encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    if "BitWatch" in python_blocks()[index]:
        # the seeded ESR fault is found on the bus and named
        assert re.search(r"^True esr ", done.stdout, re.M), done.stdout


def test_the_readme_test_command_is_what_ci_runs() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    shown = [line for block in re.findall(r"```sh\n(.*?)```", README, re.S)
             for line in block.splitlines() if "pytest" in line]
    assert shown, "README.md: no test command"
    assert shown[0] in ci, "README.md's test command differs from .ci/run's"
