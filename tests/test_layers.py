"""Which package may import which: storage under its views, the drivers under the product.

Checked on every module's syntax tree (``ast``: an import inside a function or under
``TYPE_CHECKING`` counts too):

* ``mapr_daemon/catalog/`` (storage) imports neither its views (``mapr_daemon.views``) nor the
  CLI: views read the catalog, the catalog formats nothing;
* ``drivers/`` imports nothing of ``mapr_daemon`` (the bus drivers stand alone);
* nothing in ``mapr_daemon/`` or ``drivers/`` imports ``tests`` (``tests.support`` is for the
  tests and the benches only).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def imported(source: str) -> list[tuple[int, str]]:
    """(line, module) of every absolute import in ``source``."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found += [(node.lineno, node.module)]
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def breaches(folder: str, forbidden: tuple[str, ...]) -> list[str]:
    """``path:line: imports name`` for each import under ``folder`` of a forbidden package."""
    bad = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        for line, name in imported(path.read_text(encoding="utf-8")):
            if any(name == f or name.startswith(f + ".") for f in forbidden):
                bad.append(f"{path.relative_to(ROOT).as_posix()}:{line}: imports {name}")
    return bad


def test_storage_imports_no_view() -> None:
    assert breaches("mapr_daemon/catalog", ("mapr_daemon.views", "mapr_daemon.cli")) == []


def test_drivers_import_nothing_of_the_product() -> None:
    assert breaches("drivers", ("mapr_daemon",)) == []


def test_the_product_imports_no_test_code() -> None:
    assert breaches("mapr_daemon", ("tests",)) + breaches("drivers", ("tests",)) == []


def test_the_check_sees_imports_in_functions() -> None:
    source = "import os\nfrom mapr_daemon.views import text\n\ndef f():\n    import tests.support\n"
    assert [(n, m) for n, m in imported(source) if m != "os"] == [
        (2, "mapr_daemon.views"), (2, "mapr_daemon.views.text"), (5, "tests.support")]
