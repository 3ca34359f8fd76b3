"""Reading one YAML section of a config file against a dataclass, naming file:line:field.

The daemon config (:mod:`.config`) reads its sections with it, and so does any part that
reads a section of its own from the same file (the simulator's ``testbed:``), so a wrong key,
type or value is the same one-line :class:`~mapr_daemon.errors.ConfigError` wherever it is
read. Relative paths resolve against the config file's directory.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node


class SectionReader:
    """Checks one YAML mapping against a dataclass, naming file:line:field on any error."""

    def __init__(self, path: str, base: Path) -> None:
        self.path = path
        self.base = base

    def error(self, node: Node, key: str, prefix: str, message: str) -> ConfigError:
        """The error for ``key`` of ``node``: its file, line and dotted field."""
        return ConfigError(message, path=self.path, line=node.line_of(key),
                           field=f"{prefix}{key}")

    def mapping(self, node: Any, cls: type[Any], prefix: str, parent: Node | None = None,
                key: str = "") -> dict[str, Any]:
        """The keys of the mapping ``node`` (None: none), each one a field of ``cls``."""
        if node is None:
            return {}
        if not isinstance(node, Node):
            line = parent.line_of(key) if parent is not None else 1
            raise ConfigError("expected a mapping", path=self.path, line=line,
                              field=prefix.rstrip(".") or None)
        fields = {f.name: f for f in dataclasses.fields(cls) if f.name != "source"}
        out: dict[str, Any] = {}
        for name, value in node.items():
            if name not in fields:
                raise self.error(node, str(name), prefix,
                                 f"unknown key (known: {', '.join(fields)})")
            out[str(name)] = value
        return out

    def value(self, node: Node, key: str, prefix: str, value: Any, kind: str,
              *, minimum: float | None = None, choices: tuple[str, ...] = (),
              optional: bool = False) -> Any:
        """``value`` checked to be of ``kind`` (int, float, str, bool, path, dict)."""
        if value is None and optional:
            return None
        ok = {"int": isinstance(value, int) and not isinstance(value, bool),
              "float": isinstance(value, (int, float)) and not isinstance(value, bool),
              "str": isinstance(value, str), "path": isinstance(value, str) and bool(value),
              "bool": isinstance(value, bool), "dict": isinstance(value, dict)}[kind]
        if not ok:
            raise self.error(node, key, prefix, f"expected {kind}, got {value!r}")
        if kind == "float" and not math.isfinite(value):
            raise self.error(node, key, prefix, f"expected a finite number, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.error(node, key, prefix, f"must be >= {minimum:g}, got {value!r}")
        if choices and value not in choices:
            raise self.error(node, key, prefix,
                             f"expected one of {', '.join(choices)}, got {value!r}")
        if kind == "float":
            return float(value)
        if kind == "path":
            return str(self.base / os.path.expanduser(value))
        if kind == "dict":
            return {str(k): v for k, v in value.items()}
        return value


def read_section(r: SectionReader, root: Node, key: str, cls: type[Any],
             spec: dict[str, tuple[str, dict[str, Any]]]) -> Any:
    """Section ``key`` of ``root`` as a ``cls``: each key checked by its ``spec`` (kind and
    :meth:`SectionReader.value` options; kind ``skip``: read elsewhere), absent ones default."""
    node = root.get(key)
    raw = r.mapping(node, cls, f"{key}.", root, key)
    kwargs = {}
    for name, value in raw.items():
        kind, opts = spec[name]
        if kind == "skip":   # a list parsed by its own reader
            continue
        assert isinstance(node, Node)
        kwargs[name] = r.value(node, name, f"{key}.", value, kind, **opts)
    return cls(**kwargs)
