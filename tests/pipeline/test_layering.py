"""The pipeline is shared by the daemon, ``mapr replay`` and ``mapr fleet``: it imports
nothing of the service around it (checked on every module's syntax tree, so an import in a
function or under ``TYPE_CHECKING`` counts too)."""

from __future__ import annotations

import ast
from pathlib import Path

PIPELINE = Path(__file__).resolve().parents[2] / "mapr_daemon" / "pipeline"


def test_the_pipeline_imports_nothing_of_the_service() -> None:
    modules = sorted(PIPELINE.glob("*.py"))
    assert len(modules) >= 6
    bad = []
    for path in modules:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            bad += [f"{path.name}:{node.lineno}: {n}" for n in names
                    if n == "mapr_daemon.service" or n.startswith("mapr_daemon.service.")]
    assert bad == []
