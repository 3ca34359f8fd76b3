"""The simulator is a leaf: nothing in the product imports ``mapr_daemon.testbed``.

The rule, checked on every module's syntax tree (``ast``, so an import that is never run
counts too): inside ``mapr_daemon/testbed/`` anything goes (the simulator may use production
code); elsewhere in ``mapr_daemon/`` and ``drivers/`` no module imports the testbed, at module
level, in a function, under ``TYPE_CHECKING`` or through ``importlib`` with a literal name.
There is no exception: the daemon opens the simulated aircraft as the ``testbed`` backend,
registered by name (``mapr_daemon/__init__.py``), and ``mapr demo`` and ``mapr simulate``
live in the testbed, named by module path in ``mapr``'s table of subcommands.

``bench/`` and ``tests/`` are not the product: they fly the simulator on purpose.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIMULATOR = "mapr_daemon.testbed"
def _names(node: ast.AST) -> list[str]:
    """The modules an import statement or a literal ``import_module`` call loads."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
        return [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
    if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
            and isinstance(node.args[0].value, str):
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else \
            func.id if isinstance(func, ast.Name) else ""
        if name in ("import_module", "__import__"):
            return [node.args[0].value]
    return []


def simulator_imports(source: str) -> list[tuple[int, str | None]]:
    """(line, enclosing function or None at module level) of each import of the simulator;
    a method is named ``Class.method``, a nested function by its outermost one."""
    found: list[tuple[int, str | None]] = []

    def visit(node: ast.AST, classes: str, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            inner, where = function, classes
            if function is None and isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                inner = classes + child.name
            elif function is None and isinstance(child, ast.ClassDef):
                where = f"{classes}{child.name}."
            if any(n == SIMULATOR or n.startswith(SIMULATOR + ".") for n in _names(child)):
                found.append((child.lineno, function))
            visit(child, where, inner)

    visit(ast.parse(source), "", None)
    return found


def violations(relative: str, source: str) -> list[str]:
    return [f"{relative}:{line}: imports {SIMULATOR}" + (f" in {fn}()" if fn else
                                                          " at module level")
            for line, fn in simulator_imports(source)]


def test_nothing_outside_the_testbed_imports_it() -> None:
    product = [p for package in ("mapr_daemon", "drivers")
               for p in sorted((ROOT / package).rglob("*.py"))]
    assert len(product) > 100
    bad = []
    for path in product:
        relative = path.relative_to(ROOT).as_posix()
        if relative.startswith("mapr_daemon/testbed/"):
            continue
        bad += violations(relative, path.read_text(encoding="utf-8"))
    assert bad == []


def test_the_simulators_front_ends_live_in_the_testbed() -> None:
    """``mapr demo`` and ``mapr simulate`` are registered by module path, from the testbed."""
    from mapr_daemon.cli.main import MODULES, build_parser

    front_ends = sorted(m for m in MODULES.values() if m.startswith(SIMULATOR + "."))
    assert front_ends == ["mapr_daemon.testbed.cli_demo", "mapr_daemon.testbed.cli_simulate"]
    help_text = build_parser().format_help()
    assert "demo" in help_text and "simulate" in help_text


def test_the_check_sees_every_form_of_import() -> None:
    source = '''
import mapr_daemon.testbed.aircraft
from mapr_daemon.testbed import profiles
from mapr_daemon import testbed
from mapr_daemon.ema import testbed_like
if TYPE_CHECKING:
    from mapr_daemon.testbed.aircraft import Aircraft

def run():
    from mapr_daemon.testbed.loopback import testbed_factory
    importlib.import_module("mapr_daemon.testbed.mismatch")

class Watch:
    def feed(self):
        import mapr_daemon.testbed
'''
    assert [line for line, _ in simulator_imports(source)] == [2, 3, 4, 7, 10, 11, 15]
    assert violations("mapr_daemon/cli/x.py", source) == [
        f"mapr_daemon/cli/x.py:{n}: imports {SIMULATOR} at module level" for n in (2, 3, 4, 7)
    ] + [f"mapr_daemon/cli/x.py:{n}: imports {SIMULATOR} in run()" for n in (10, 11)
         ] + [f"mapr_daemon/cli/x.py:15: imports {SIMULATOR} in Watch.feed()"]
