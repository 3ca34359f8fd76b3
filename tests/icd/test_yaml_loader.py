"""Tables load the same through libyaml's parser as through PyYAML's own: values, types,
and the line of every mapping and key (which error messages name); a syntax error is
worded by the pure-Python parser either way."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from mapr_daemon.errors import IcdError
from mapr_daemon.icd import yamlsrc
from mapr_daemon.icd.yamlsrc import Node, load_text

ROOT = Path(__file__).resolve().parents[2]
TABLES = sorted([*ROOT.glob("configs/icd/*.yaml"), *ROOT.glob("tests/data/icd/*.yaml")])


def same(a: Any, b: Any) -> None:
    assert type(a) is type(b)
    if isinstance(a, Node):
        assert list(a) == list(b) and a.line == b.line and a.key_lines == b.key_lines
        for key in a:
            same(a[key], b[key])
    elif isinstance(a, list):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            same(x, y)
    else:
        assert a == b


@pytest.mark.parametrize("table", TABLES, ids=lambda p: p.name)
def test_libyaml_loads_what_the_python_parser_loads(table: Path) -> None:
    text = table.read_text(encoding="utf-8") + "\nextra: {flag: OFF, big: 1e7, yes: true}\n"
    loaded = load_text(text, str(table))
    same(loaded, yaml.load(text, Loader=yamlsrc._LineLoader))
    assert loaded["extra"] == {"flag": "OFF", "big": 1e7, "yes": True}


def test_a_syntax_error_names_the_line() -> None:
    with pytest.raises(IcdError) as caught:
        load_text("messages:\n  - name: a\n    rt: [1, 2\n", "t.yaml")
    assert caught.value.line == 4 and "invalid YAML" in str(caught.value)
