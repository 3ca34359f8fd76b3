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
    """``mapr demo``, ``mapr simulate`` and ``mapr fleet-archive`` are registered by module
    path, from the testbed."""
    from mapr_daemon.cli.main import MODULES, build_parser

    front_ends = sorted(m for m in MODULES.values() if m.startswith(SIMULATOR + "."))
    assert front_ends == ["mapr_daemon.testbed.cli_demo", "mapr_daemon.testbed.cli_fleet_archive",
                          "mapr_daemon.testbed.cli_simulate"]
    help_text = build_parser().format_help()
    assert "demo" in help_text and "simulate" in help_text and "fleet-archive" in help_text


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


# ---------------------------------------------------------------------------------------------
# Layering: every package on a floor, imports only go down, and no module import cycle.

FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors", "arrays", "findings", "utc"),
    ("ema", "icd"),
    ("catalog", "reasoner.diagnosis", "reasoner.ekf"),
    ("reasoner.prognosis",),
    ("reasoner.training",),
    ("reasoner.commissioning",),
    ("reasoner",),
    ("pipeline", "views"),
    ("service",),
    ("fleet",),
    ("cli",),
    ("testbed",),
)
"""The floors of ``mapr_daemon``, bottom first. A package imports only packages on lower
floors (and itself); packages on one floor do not import each other. ``reasoner`` alone is
its face (``reasoner/__init__.py``, ``reasoner/reasoner.py``); its sub-packages read as the
reasoner's pipeline: diagnose, estimate, trend, train, commission."""

REASONER_SUBPACKAGES = ("diagnosis", "ekf", "prognosis", "training", "commissioning")


def unit_of(module: str) -> str | None:
    """The floor-table unit a dotted module belongs to (None outside ``mapr_daemon``)."""
    parts = module.split(".")
    if parts[0] != "mapr_daemon" or len(parts) < 2:
        return None
    if parts[1] == "reasoner" and len(parts) > 2 and parts[2] in REASONER_SUBPACKAGES:
        return f"reasoner.{parts[2]}"
    return parts[1]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(package: str, node: ast.Import | ast.ImportFrom, known: set[str]) -> list[str]:
    """The project modules an import statement in a module of ``package`` loads: ``from pkg
    import name`` is the module ``pkg.name`` when there is one, else ``pkg`` itself."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in known]
    base = node.module or ""
    if node.level:
        anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
        base = ".".join(anchor + ([base] if base else []))
    out = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in known]
    if len(out) < len(node.names) and base in known:
        out.append(base)
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (anywhere in it: module level, functions,
    ``TYPE_CHECKING`` blocks)."""
    paths = {module_name(p): p for package in ("mapr_daemon", "drivers")
             for p in sorted((ROOT / package).rglob("*.py"))}
    known = set(paths)
    graph: dict[str, set[str]] = {}
    for name, path in paths.items():
        targets: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                package = name if path.name == "__init__.py" else name.rpartition(".")[0]
                targets.update(t for t in _resolve(package, node, known) if t != name)
        graph[name] = targets
    return graph


def floor_violations(graph: dict[str, set[str]]) -> list[str]:
    floor = {unit: i for i, units in enumerate(FLOORS) for unit in units}
    bad = []
    for importer, targets in sorted(graph.items()):
        src = unit_of(importer)
        if src is None:
            continue
        if src not in floor:
            bad.append(f"{importer}: package {src} has no floor in FLOORS")
            continue
        for target in sorted(targets):
            dst = unit_of(target)
            if dst is None or dst == src:
                continue
            if dst not in floor or floor[dst] >= floor[src]:
                bad.append(f"{importer} imports {target}: {src} (floor {floor[src]}) may not "
                           f"import {dst} (floor {floor.get(dst)})")
    return bad


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_every_package_imports_only_the_floors_below_it() -> None:
    assert floor_violations(import_graph()) == []


def test_no_module_import_cycle() -> None:
    assert cycles(import_graph()) == []


def test_relative_imports_resolve_from_their_package() -> None:
    known = {"mapr_daemon.reasoner.diagnosis", "mapr_daemon.reasoner.diagnosis.parts",
             "mapr_daemon.reasoner.ekf"}
    face = ast.parse("from .parts import COMPONENTS\nfrom ..ekf import NEEDED").body
    assert _resolve("mapr_daemon.reasoner.diagnosis", face[0], known) == [
        "mapr_daemon.reasoner.diagnosis.parts"]
    assert _resolve("mapr_daemon.reasoner.diagnosis", face[1], known) == [
        "mapr_daemon.reasoner.ekf"]


def test_the_layering_checks_can_fail() -> None:
    graph = {
        "mapr_daemon.reasoner.diagnosis.features": {"mapr_daemon.reasoner.prognosis.trend"},
        "mapr_daemon.reasoner.prognosis.trend": {"mapr_daemon.reasoner.diagnosis.features"},
        "mapr_daemon.catalog.reader": {"mapr_daemon.reasoner.diagnosis.features"},
        "mapr_daemon.nowhere.x": set(),
    }
    assert floor_violations(graph) == [
        "mapr_daemon.catalog.reader imports mapr_daemon.reasoner.diagnosis.features: catalog "
        "(floor 2) may not import reasoner.diagnosis (floor 2)",
        "mapr_daemon.nowhere.x: package nowhere has no floor in FLOORS",
        "mapr_daemon.reasoner.diagnosis.features imports mapr_daemon.reasoner.prognosis.trend: "
        "reasoner.diagnosis (floor 2) may not import reasoner.prognosis (floor 3)",
    ]
    assert cycles(graph) == [["mapr_daemon.reasoner.diagnosis.features",
                              "mapr_daemon.reasoner.prognosis.trend"]]


def test_one_float_array_alias() -> None:
    """``FloatArray`` is defined once for the aircraft side (``mapr_daemon/arrays.py``)."""
    defining = [p.relative_to(ROOT).as_posix() for p in sorted((ROOT / "mapr_daemon").rglob("*.py"))
                if any(isinstance(n, ast.Assign) and any(isinstance(t, ast.Name) and
                                                         t.id == "FloatArray" for t in n.targets)
                       for n in ast.parse(p.read_text(encoding="utf-8")).body)]
    assert defining == ["mapr_daemon/arrays.py"]
