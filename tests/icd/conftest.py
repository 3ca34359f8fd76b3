"""Fixtures of the ICD tests: the EMA table, and one-parameter tables from YAML snippets."""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from mapr_daemon.icd import Icd, load_icd, loads_icd

REPO = Path(__file__).resolve().parents[2]
EMA_TABLE = REPO / "configs" / "icd" / "ema-testbed.yaml"
DATA = REPO / "tests" / "data" / "icd"


def _one_parameter(spec: str, *, wc: int = 2, tr: str = "T") -> Icd:
    """A table with one message (RT 1, SA 1, ``wc`` words) holding the parameter ``spec``,
    given as a YAML flow mapping without its name (it is called ``p``)."""
    text = textwrap.dedent(f"""\
        spec: 1
        name: t
        terminals: [{{address: 1, name: rt1}}]
        messages:
          - name: m
            rt: rt1
            tr: {tr}
            sa: 1
            wc: {wc}
            rate_hz: 0
            parameters:
              - {{name: p, word: 0, {spec}}}
        """)
    return loads_icd(text, "one.yaml")


@pytest.fixture(scope="session")
def one_parameter() -> Callable[..., Icd]:
    """``one_parameter("type: twos, lsb: 0.5")``: a table whose message ``m`` holds ``p``."""
    return _one_parameter


@pytest.fixture(scope="session")
def ema() -> Icd:
    """The EMA testbed table, loaded once."""
    return load_icd(EMA_TABLE)


@pytest.fixture(scope="session")
def ema_path() -> Path:
    """configs/icd/ema-testbed.yaml."""
    return EMA_TABLE


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """tests/data/icd: fixture tables and golden outputs."""
    return DATA
