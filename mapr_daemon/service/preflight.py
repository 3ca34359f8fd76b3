"""What the daemon will meet on this machine, checked before it starts (``mapr run``,
``mapr run --check``, and a SIGHUP reload).

A config can be well-formed and still not work: a file-reading backend (``capture``,
``chapter10``) whose file is missing (the daemon would retry opening it for ever), a backend
option it does not take or a time option that is not a finite positive number (every open
would fail, retried for ever), an ICD, dictionary or actuator file that cannot be read, a
recording directory that is a file or cannot be written (recording would stop at the first
record while monitoring goes on), a catalog path that is a directory or whose directory is
missing or not writable. Under systemd each of those is a "running" service doing nothing
useful, so each is a :class:`~mapr_daemon.errors.ConfigError` naming the config file and line
(exit 78). Writability is tried (a file created and removed), not inferred from permission
bits, which say nothing for root or on a read-only file system. A backend
that can never open on this machine (its Python module or its system library, e.g. libusb,
is missing) is a :class:`~drivers.errors.BackendUnavailable` naming the same (exit 69).

These checks look at the filesystem, so they are not part of parsing: ``mapr replay`` and
``mapr devices`` read the same config (:func:`~mapr_daemon.service.config.load_config`) but
never open its backend or its recording directory; the daemon loads its config with
:func:`load_checked`.
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drivers.errors import BackendOptionError, BackendUnavailable
from mapr_daemon import TESTBED_BACKEND
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node
from mapr_daemon.service.config import Config, parse, read

if TYPE_CHECKING:
    from drivers.monitor import BusMonitor

FILE_BACKENDS = ("capture", "chapter10")
"""Backends that read a file named by their ``path`` option."""


def load_checked(path: str | os.PathLike[str] | None) -> Config:
    """The daemon's config in ``path`` (None: the built-in defaults), parsed and then checked
    against this machine (:func:`check`): what ``mapr run``, its ``--check`` and a SIGHUP
    reload load. ConfigError (exit 78) or BackendUnavailable (exit 69)."""
    if path is None:
        return Config()
    text_path = os.fspath(path)
    raw = read(text_path)
    config = parse(raw, text_path)
    check(config, raw, text_path)
    return config


def check(config: Config, raw: Any, path: str) -> None:
    """Raise ConfigError for the first thing in ``config`` (parsed from ``raw``, the YAML
    of ``path``) the daemon could not use here."""
    root = raw if isinstance(raw, Node) else None
    _backend(config, _node(root, "backend"), path)
    _assets(config, root, path)
    _icd(config, root, path)
    _reasoner_dictionary(config, root, path)
    _backend_numbers(config, _node(root, "backend"), path)
    _record(config, _node(root, "record"), path)
    _catalog(config, _node(root, "catalog"), path)


def _node(parent: Node | None, key: str) -> Node | None:
    child = parent.get(key) if parent is not None else None
    return child if isinstance(child, Node) else parent


def _error(node: Node | None, key: str, field: str, message: str, path: str) -> ConfigError:
    line = node.line_of(key) if node is not None else None
    return ConfigError(message, path=path, line=line, field=field)


def _backend(config: Config, node: Node | None, path: str) -> None:
    backend = config.backend
    options = node.get("options") if node is not None else None
    where = options if isinstance(options, Node) else node
    cls = _loadable(config, node, path)
    if backend.name in FILE_BACKENDS:
        _file_backend(config, where, path)
    if backend.name != TESTBED_BACKEND:  # its options are the testbed's, checked there
        _options(config, cls, node, where, path)


def _file_backend(config: Config, where: Node | None, path: str) -> None:
    backend = config.backend
    name = backend.options.get("path")
    if not isinstance(name, str) or not name:
        raise _error(where, "path", "backend.options.path",
                     f"the {backend.name} backend needs the file to read", path)
    problem = _unreadable(Path(name))
    if problem:
        raise _error(where, "path", "backend.options.path", f"{name}: {problem}", path)
    speed = backend.options.get("speed")
    if backend.name == "chapter10" and speed is not None and not (
            isinstance(speed, (int, float)) and not isinstance(speed, bool)
            and math.isfinite(speed) and speed >= 0):
        raise _error(where, "speed", "backend.options.speed",
                     f"expected a finite number >= 0, got {speed!r}", path)


def _assets(config: Config, root: Node | None, path: str) -> None:
    """Every asset's actuator file, dictionary, prognostic model and commissioning record
    exist and are readable (what is inside them is checked when the pipeline loads them)."""
    items = root.get("assets") if root is not None else None
    for i, asset in enumerate(config.assets):
        node = items[i] if isinstance(items, list) and i < len(items) else None
        where = node if isinstance(node, Node) else root
        for key in ("actuator", "dictionary", "prognosis"):
            name = getattr(asset, key)
            problem = None if name is None else _unreadable(Path(name))
            if problem:
                raise _error(where, key, f"assets[{i}].{key}", f"{name}: {problem}", path)
        if asset.commissioned is not None:
            record = Path(asset.commissioned) / "commissioning.json"
            problem = _unreadable(record)
            if problem:
                raise _error(where, "commissioned", f"assets[{i}].commissioned",
                             f"{record}: {problem} (a mapr commission folder)", path)


def _reasoner_dictionary(config: Config, root: Node | None, path: str) -> None:
    name = config.reasoner.dictionary
    problem = None if name is None else _unreadable(Path(name))
    if problem:
        raise _error(_node(root, "reasoner"), "dictionary", "reasoner.dictionary",
                     f"{name}: {problem}", path)


def _backend_numbers(config: Config, node: Node | None, path: str) -> None:
    """The backend's numeric options are finite, its times (``*_s``) > 0: a NaN time-out
    would make every open fail, retried for ever."""
    options = node.get("options") if node is not None else None
    where = options if isinstance(options, Node) else node
    for name, value in config.backend.options.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        field = f"backend.options.{name}"
        if not math.isfinite(value):
            raise _error(where, name, field, f"expected a finite number, got {value!r}", path)
        if name.endswith("_s") and value <= 0:
            raise _error(where, name, field, f"a time must be > 0 seconds, got {value!r}",
                         path)


def _loadable(config: Config, node: Node | None, path: str) -> type[BusMonitor]:
    """The backend's class; BackendUnavailable (``mapr run`` exits 69, and systemd does not
    restart it) when the backend can never open here: its module or library is missing.
    Retrying would not help, so the daemon says so once instead of retrying for ever."""
    from drivers.monitor import backend_class

    name = config.backend.name
    try:
        cls = backend_class(name)
        check = getattr(cls, "check_loadable", None)
        if callable(check):
            check()
    except BackendUnavailable as error:
        line = node.line_of("name") if node is not None else None
        where = f"{path}:{line}" if line is not None else path
        raise BackendUnavailable(f"{where}: backend.name: {error}") from error
    return cls


def _options(config: Config, cls: type[BusMonitor], node: Node | None,
             options: Node | None, path: str) -> None:
    """Options the backend does not take, or lacks: a ConfigError on the option's line."""
    from drivers.monitor import check_options

    try:
        check_options(config.backend.name, cls, dict(config.backend.options))
    except BackendOptionError as error:
        if error.option in config.backend.options:
            raise _error(options, error.option, f"backend.options.{error.option}",
                         str(error), path) from error
        raise _error(node, "name", "backend.options", str(error), path) from error


def _icd(config: Config, node: Node | None, path: str) -> None:
    problem = _unreadable(Path(config.icd))
    if problem:
        raise _error(node, "icd", "icd", f"{config.icd}: {problem} (a relative path is read "
                     "from the config file's directory)", path)


def _unreadable(file: Path) -> str | None:
    if not file.exists():
        return "no such file"
    if not file.is_file():
        return "not a regular file"
    if not os.access(file, os.R_OK):
        return "not readable by this user"
    return None


def _record(config: Config, node: Node | None, path: str) -> None:
    directory = config.record.path
    if directory is None:
        return
    problem = _unwritable_directory(Path(directory))
    if problem and Path(directory).exists() and not Path(directory).is_dir():
        problem += " (recordings are files in a directory)"
    if problem:
        raise _error(node, "path", "record.path", f"{directory}: {problem}", path)


def _cannot_write_in(directory: Path) -> str | None:
    """Why no file can be created in the existing ``directory`` (None: one was): tried, since
    permission bits do not tell for root, ACLs or a read-only file system."""
    try:
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".mapr-check-"):
            return None
    except OSError as error:
        return error.strerror or str(error)


def _unwritable_directory(directory: Path) -> str | None:
    """Why files could not be created in ``directory``, made first if missing (None: they
    can)."""
    if directory.exists():
        if not directory.is_dir():
            return "exists and is not a directory"
        problem = _cannot_write_in(directory)
        return f"directory not writable: {problem}" if problem else None
    parent = directory.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        return f"cannot be created: {parent} is not a directory"
    problem = _cannot_write_in(parent)
    return f"cannot be created in {parent}: {problem}" if problem else None


def _catalog(config: Config, node: Node | None, path: str) -> None:
    catalog = Path(config.catalog.path)
    if catalog.is_dir():
        raise _error(node, "path", "catalog.path",
                     f"{catalog}: is a directory (the catalog is a file)", path)
    # A missing directory passes if it can be made (systemd's StateDirectory= makes it).
    problem = _unwritable_directory(catalog.parent)
    if problem:
        raise _error(node, "path", "catalog.path", f"{catalog}: {catalog.parent}: {problem}",
                     path)
