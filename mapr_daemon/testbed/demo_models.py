"""The demo's fault dictionaries and prognostic models: shipped pre-built, keyed by what built them.

``mapr demo`` diagnoses two stock actuator types (the aileron at 2 kHz, the elevator at 1 kHz,
:data:`STOCK`) and needs, per type, a fault dictionary and a prognostic model. Building them
takes minutes of CPU (thousands of simulated BITs), too long for a first run, so the package
ships them pre-built (``mapr_daemon/testbed/models/``, compressed ``.npz``, about 1 MB a
pair) with a manifest that says what built them.

**Why a digest of the build's inputs, and which.** A pre-built model is only right while the
code that built it is unchanged. Each pair's key (:func:`models_key`) is a digest of the spec
file, the actuator file, the sample rate it was built at, both file formats, and the source of
every module the two builds can run: the static import closure
(:func:`build_sources`) of the dictionary and prognosis builds within this project
(``mapr_daemon``, ``drivers``), function-local and type-checking imports included, so
over-inclusive rather than short. A change to the plant, the BIT profile, the reasoner or a
build changes the key; a change to the CLI, the catalog or the demo itself does not. The
manifest stores the key and a digest per source file, so a stale pair names the files that
changed. Library versions (numpy, numba) are recorded, not keyed: they move results by
rounding, not by design.

The demo uses a shipped pair whose key matches; otherwise the user's cache (the same key),
otherwise it builds and caches one (:func:`.demo_reasoner.cached_models`, with
:func:`build_dictionary` and :func:`build_prognosis`: a progress line with the time left).
``tests/testbed/test_demo_models.py`` fails when a shipped pair's key no longer matches the
code; rebuild with ``python3 -m mapr_daemon.testbed.demo_models`` (it rebuilds only the stale
pairs and prints what it took).
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import hashlib
import json
import platform
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mapr_daemon.cli.commands.dictionary import default_spec_path, peak_rss_mb
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path

PACKAGE = Path(__file__).resolve().parents[1]
"""``mapr_daemon/``."""
ROOT = PACKAGE.parent
"""The directory holding the project's packages: source paths in a key are relative to it."""
PROJECT_PACKAGES = ("mapr_daemon", "drivers")
"""Top-level packages whose modules the import closure follows (others are libraries)."""
BUILD_ENTRIES = ("mapr_daemon.reasoner.training.dictionary_build",
                 "mapr_daemon.reasoner.training.prognosis_build",
                 "mapr_daemon.reasoner.diagnosis.dictionary",
                 "mapr_daemon.reasoner.prognosis.prognostic_model")
"""The builds and the two file formats: their import closure decides what a model holds."""
SHIPPED_DIR = Path(__file__).resolve().parent / "models"
"""Where the pre-built pairs and their manifest live (package data)."""
MANIFEST = SHIPPED_DIR / "manifest.json"


def demo_spec_path() -> Path:
    """The demo's dictionary spec (``configs/reasoner/dictionary-demo.yaml``): the shipped
    spec with three pressures and eight severities, so a pair ships at about 1.8 MB."""
    return default_spec_path().with_name("dictionary-demo.yaml")


@dataclasses.dataclass(frozen=True)
class Stock:
    """One stock actuator type the demo flies, at the rate it is sampled on the bus."""

    actuator: str
    """File name in ``configs/actuators/``."""
    sample_rate_hz: float

    @property
    def path(self) -> Path:
        return default_actuator_path().with_name(self.actuator)

    @property
    def stem(self) -> str:
        """File-name stem of its pair: ``aileron-uav-2000hz``."""
        return f"{Path(self.actuator).stem}-{self.sample_rate_hz:g}hz"


STOCK = (Stock("aileron-uav.yaml", 2000.0), Stock("elevator-uav.yaml", 1000.0))
"""The demo's two EMAs (:func:`~mapr_daemon.testbed.cli_demo.emas`)."""


def module_path(name: str) -> Path | None:
    """The source file of project module ``name`` (a package's ``__init__.py``), or None if
    it is not one of the project's modules."""
    if name.split(".")[0] not in PROJECT_PACKAGES:
        return None
    base = ROOT.joinpath(*name.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _imported(path: Path, name: str) -> set[str]:
    """Every module name an import statement in ``path`` (module ``name``) may load: each
    ``import a.b``, each ``from a import b`` as ``a`` and ``a.b`` (``b`` may be a submodule),
    relative imports resolved; anywhere in the file, not only at the top."""
    is_package = path.name == "__init__.py"
    package = name if is_package else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_bytes(), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1])
                origin = f"{base}.{node.module}" if node.module else base
            else:
                origin = node.module or ""
            found.add(origin)
            found.update(f"{origin}.{alias.name}" for alias in node.names)
    return found


def build_sources(entries: tuple[str, ...] = BUILD_ENTRIES) -> list[Path]:
    """The source files of the project modules ``entries`` may import, transitively (with
    every enclosing package's ``__init__.py``: importing ``a.b.c`` runs them), sorted."""
    seen: dict[str, Path] = {}
    todo = list(entries)
    while todo:
        name = todo.pop()
        parts = name.split(".")
        for i in range(1, len(parts) + 1):
            prefix = ".".join(parts[:i])
            if prefix in seen:
                continue
            path = module_path(prefix)
            if path is None:
                continue
            seen[prefix] = path
            todo.extend(_imported(path, prefix))
    return sorted(set(seen.values()))


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


def source_digests() -> dict[str, str]:
    """Each build source, by its path relative to the project root, and its digest."""
    return {p.relative_to(ROOT).as_posix(): _file_digest(p) for p in build_sources()}


def formats() -> dict[str, str]:
    """The dictionary's and the prognostic model's file formats."""
    from mapr_daemon.reasoner.diagnosis.dictionary import FORMAT as DICTIONARY
    from mapr_daemon.reasoner.prognosis.prognostic_model import FORMAT as PROGNOSIS
    return {"dictionary": DICTIONARY, "prognosis": PROGNOSIS}


def models_key(spec_path: Path, actuator_path: Path, sample_rate_hz: float,
               sources: dict[str, str] | None = None) -> str:
    """The digest of everything a built dictionary and model depend on: the spec's and the
    actuator file's content, the rate, the formats and the build's sources (``sources``:
    :func:`source_digests`, computed if not given)."""
    digest = hashlib.sha256()
    digest.update(f"rate={sample_rate_hz:.6g}\n".encode())
    for kind, version in sorted(formats().items()):
        digest.update(f"{kind}={version}\n".encode())
    digest.update(b"spec=" + spec_path.read_bytes() + b"\n")
    digest.update(b"actuator=" + actuator_path.read_bytes() + b"\n")
    for name, file_digest in sorted((sources or source_digests()).items()):
        digest.update(f"{name}={file_digest}\n".encode())
    return digest.hexdigest()[:16]


def read_manifest() -> dict[str, Any]:
    """The shipped pairs' manifest (empty when none is shipped)."""
    if not MANIFEST.is_file():
        return {"pairs": {}}
    data: dict[str, Any] = json.loads(MANIFEST.read_text())
    return data


def shipped(stock_stem: str, key: str) -> tuple[Path, Path] | None:
    """The shipped dictionary and model of ``stock_stem`` if they were built under ``key``."""
    entry = read_manifest()["pairs"].get(stock_stem)
    if entry is None or entry.get("key") != key:
        return None
    dictionary, prognosis = SHIPPED_DIR / entry["dictionary"], SHIPPED_DIR / entry["prognosis"]
    if not (dictionary.is_file() and prognosis.is_file()):
        return None
    return dictionary, prognosis


def stock_for(actuator_path: Path, sample_rate_hz: float) -> Stock | None:
    """The stock type this actuator file at this rate is, if it is one (same content as the
    shipped file of that name)."""
    for stock in STOCK:
        if stock.sample_rate_hz == sample_rate_hz and stock.path.is_file() \
                and actuator_path.is_file() \
                and stock.path.read_bytes() == actuator_path.read_bytes():
            return stock
    return None


def stale(spec_path: Path | None = None) -> dict[str, str]:
    """Each stock pair that is missing or no longer matches the code, and why (empty: every
    shipped pair matches)."""
    spec_path = spec_path or demo_spec_path()
    manifest = read_manifest()
    sources = source_digests()
    why: dict[str, str] = {}
    for stock in STOCK:
        entry = manifest["pairs"].get(stock.stem)
        if entry is None:
            why[stock.stem] = "not shipped"
            continue
        if entry.get("key") == models_key(spec_path, stock.path, stock.sample_rate_hz, sources):
            missing = [entry[f] for f in ("dictionary", "prognosis")
                       if not (SHIPPED_DIR / entry[f]).is_file()]
            if missing:
                why[stock.stem] = f"missing {', '.join(missing)}"
            continue
        built = entry.get("sources", {})
        changed = sorted(n for n in set(built) | set(sources) if built.get(n) != sources.get(n))
        inputs = [label for label, field, now in (
            ("spec", "spec_digest", _file_digest(spec_path)),
            ("actuator file", "actuator_digest", _file_digest(stock.path)))
            if entry.get(field) != now]
        if entry.get("formats") != formats():
            inputs.append("file formats")
        why[stock.stem] = "changed since it was built: " + ", ".join(inputs + changed or
                                                                     ["(unknown)"])
    return why


class ProgressLine:
    """A build's progress on stderr, with the time it has taken and an estimate of the time
    left from the rate so far (after the first 5 %: earlier the rate says little); at 100 %
    it says what follows the simulation (``then``: fitting, not counted in the estimate). A
    terminal gets one line redrawn at every whole percent, a log one line per tenth."""

    def __init__(self, label: str, then: str) -> None:
        self.label, self.then = label, then
        self.started = time.monotonic()
        self.tty = sys.stderr.isatty()
        self.shown = -1

    def __call__(self, fraction: float) -> None:
        step = int(100 * fraction) if self.tty else 10 * int(10 * fraction)
        if step == self.shown:
            return
        self.shown = step
        elapsed = time.monotonic() - self.started
        left = ""
        if 0.05 <= fraction < 1.0:
            left = f", about {elapsed / fraction * (1.0 - fraction):.0f} s left"
        elif fraction >= 1.0:
            left = f"; {self.then}"
        if self.tty:
            print(f"\r  {self.label}: {step:3d} % ({elapsed:.0f} s{left})   ", end="",
                  file=sys.stderr, flush=True)
        else:
            print(f"  {self.label}: {step:3d} % ({elapsed:.0f} s{left})", file=sys.stderr,
                  flush=True)

    def done(self, what: str) -> None:
        """The closing line: what was built, in how long, at what peak memory."""
        line = f"  {what} in {time.monotonic() - self.started:.0f} s (peak memory " \
            f"{peak_rss_mb():.0f} MB)"
        print(f"\r{line}{' ' * 40}" if self.tty else line, file=sys.stderr)


def last_build_cpu_s(params: ActuatorParams, actuator_path: Path) -> float | None:
    """CPU seconds the shipped pair of this type took to build (its manifest), if shipped."""
    stock = stock_for(actuator_path, params.sensors.sample_rate_hz)
    entry = None if stock is None else read_manifest()["pairs"].get(stock.stem)
    return None if entry is None else float(entry["built"]["cpu_s"])


def _save(write: Callable[[Path], None], path: Path) -> None:
    """Write through a temporary name: a killed build never leaves a half file under a key."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".partial.npz")
    write(partial)
    partial.replace(path)


def build_dictionary(params: ActuatorParams, spec_path: Path, path: Path,
                     cpu_hint_s: float | None) -> None:
    """Build this type's fault dictionary into ``path``, progress on stderr."""
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training.dictionary_build import build
    hint = "" if cpu_hint_s is None else \
        f"; the dictionary and model together took {cpu_hint_s:.0f} s of CPU when last built"
    print(f"Building the {params.name} fault dictionary at {params.sensors.sample_rate_hz:g} "
          f"Hz ({spec_path.name}{hint}); it is kept in {path.parent}", file=sys.stderr)
    line = ProgressLine("dictionary: simulating fault-seeded BITs",
                        "fitting the healthy and fault models, calibrating the thresholds")
    dictionary = build(params, DictionarySpec.load(spec_path), progress=line)
    _save(dictionary.save, path)
    line.done("dictionary built")


def build_prognosis(params: ActuatorParams, dictionary_path: Path, path: Path,
                    cpu_hint_s: float | None) -> None:
    """Build this type's prognostic model from its dictionary into ``path``, progress on
    stderr."""
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.prognosis_build import build_prognostic_model
    print(f"Building the {params.name} prognostic model (degradation estimators, their noise, "
          f"fleet priors); it is kept in {path.parent}", file=sys.stderr)
    line = ProgressLine("prognostic model: simulating BITs at known wear",
                        "fitting the estimators and their noise, learning the fleet priors")
    model = build_prognostic_model(Dictionary.load(dictionary_path), params, progress=line)
    _save(model.save, path)
    line.done("prognostic model built")


def cpu_s() -> float:
    """This process's user + system CPU seconds so far."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def rebuild(spec_path: Path | None = None, *, only_stale: bool = True) -> list[str]:
    """Build the stock pairs (the stale ones, or all) into :data:`SHIPPED_DIR` and write the
    manifest; returns the stems built. Progress on stderr."""
    from mapr_daemon.ema.params import load_actuator, with_sample_rate
    spec_path = spec_path or demo_spec_path()
    todo = stale(spec_path) if only_stale else {s.stem: "asked" for s in STOCK}
    manifest = read_manifest()
    sources = source_digests()
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    built = []
    for stock in STOCK:
        if stock.stem not in todo:
            continue
        print(f"{stock.stem}: {todo[stock.stem]}", file=sys.stderr)
        params = with_sample_rate(load_actuator(stock.path), stock.sample_rate_hz)
        dictionary = SHIPPED_DIR / f"dictionary-{stock.stem}.npz"
        prognosis = SHIPPED_DIR / f"prognosis-{stock.stem}.npz"
        started, cpu = time.monotonic(), cpu_s()
        build_dictionary(params, spec_path, dictionary, None)
        build_prognosis(params, dictionary, prognosis, None)
        manifest["pairs"][stock.stem] = {
            "key": models_key(spec_path, stock.path, stock.sample_rate_hz, sources),
            "actuator": stock.actuator, "sample_rate_hz": stock.sample_rate_hz,
            "spec_digest": _file_digest(spec_path), "actuator_digest": _file_digest(stock.path),
            "formats": formats(), "sources": sources,
            "dictionary": dictionary.name, "prognosis": prognosis.name,
            "built": {"wall_s": round(time.monotonic() - started, 1),
                      "cpu_s": round(cpu_s() - cpu, 1),
                      "python": platform.python_version(), **library_versions()}}
        built.append(stock.stem)
    MANIFEST.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return built


def library_versions() -> dict[str, str]:
    """numpy's and numba's versions (recorded with a build, not part of its key)."""
    import numba
    import numpy
    return {"numpy": numpy.__version__, "numba": numba.__version__}


def main(argv: list[str] | None = None) -> int:
    """``python3 -m mapr_daemon.testbed.demo_models [--check] [--all]``."""
    parser = argparse.ArgumentParser(prog="python3 -m mapr_daemon.testbed.demo_models",
                                     description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true",
                        help="only say which shipped pairs are stale (exit 1 if any)")
    parser.add_argument("--all", action="store_true", help="rebuild every pair, stale or not")
    args = parser.parse_args(argv)
    if args.check:
        why = stale()
        for stem, reason in why.items():
            print(f"{stem}: {reason}")
        if not why:
            print("every shipped pair matches the code")
        return 1 if why else 0
    built = rebuild(only_stale=not args.all)
    print(f"rebuilt: {', '.join(built) or 'nothing (every shipped pair matches the code)'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
