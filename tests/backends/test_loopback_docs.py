"""docs/loopback.md stays true: its example runs and its claims hold."""

from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "loopback.md"


def test_the_example_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    assert blocks, "docs/loopback.md has no python example"
    for block in blocks:
        exec(compile(block, str(DOC), "exec"), {})


def test_every_injection_kind_is_documented() -> None:
    from drivers.backends.loopback import INJECTION_KINDS
    text = DOC.read_text()
    assert all(f"`{kind}`" in text for kind in INJECTION_KINDS)
