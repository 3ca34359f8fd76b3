"""Typed access to one YAML mapping of the table, with errors that name file, line and field.

:class:`Fields` wraps a :class:`~mapr_daemon.icd.yamlsrc.Node`: each getter checks the type of
one key and raises :class:`IcdError` pointing at that key's line; :meth:`Fields.done` rejects
keys nobody asked for, so a typo (``minimun:``) is an error rather than a silent default.
"""

from __future__ import annotations

import math
from typing import Any, NoReturn

from mapr_daemon.errors import IcdError
from mapr_daemon.icd.yamlsrc import Node

_MISSING = object()


class Fields:
    """Reader for one mapping; ``where`` prefixes field names in errors (``messages[2].wc``)."""

    def __init__(self, node: Any, path: str, where: str, line: int = 0) -> None:
        if not isinstance(node, Node):
            raise IcdError(f"expected a mapping, got {_kind(node)}", path=path,
                           line=line or None, field=where or None)
        self.node = node
        self.path = path
        self.where = where
        self._seen: set[str] = set()

    @property
    def line(self) -> int:
        return self.node.line

    @property
    def lines(self) -> dict[str, int]:
        """Line of each key of the mapping."""
        return dict(self.node.key_lines)

    def name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def line_of(self, key: str) -> int:
        return self.node.line_of(key)

    def fail(self, key: str, problem: str) -> NoReturn:
        """Raise an :class:`IcdError` about ``key`` at its line."""
        raise IcdError(problem, path=self.path, line=self.line_of(key), field=self.name(key))

    def has(self, key: str) -> bool:
        return key in self.node

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        self._seen.add(key)
        if key in self.node and self.node[key] is not None:
            return self.node[key]
        if default is _MISSING:
            self.fail(key, "is required")
        return default

    def string(self, key: str, default: Any = _MISSING) -> Any:
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        if not isinstance(value, str) or not value.strip():
            self.fail(key, f"must be a non-empty string, got {_kind(value)}")
        return value

    def integer(self, key: str, default: Any = _MISSING, *, lo: int | None = None,
                hi: int | None = None) -> Any:
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"must be an integer, got {_kind(value)}")
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            self.fail(key, f"{value} is outside {lo}..{hi}")
        return value

    def number(self, key: str, default: Any = _MISSING, *, positive: bool = False) -> Any:
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"must be a number, got {_kind(value)}")
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        if positive and value <= 0:
            self.fail(key, f"must be greater than 0, got {value}")
        return float(value)

    def listing(self, key: str, default: Any = _MISSING) -> Any:
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        if not isinstance(value, list):
            self.fail(key, f"must be a list, got {_kind(value)}")
        return value

    def child(self, key: str) -> Fields:
        value = self.raw(key)
        return Fields(value, self.path, self.name(key), self.line_of(key))

    def child_at(self, key: str, index: int) -> Fields:
        """Item ``index`` of the list under ``key``, as a mapping."""
        items = self.listing(key)
        item = items[index]
        line = item.line if isinstance(item, Node) else self.line_of(key)
        return Fields(item, self.path, f"{self.name(key)}[{index}]", line)

    def done(self) -> None:
        """Reject keys that were never read (typos, unsupported options)."""
        for key in self.node:
            if str(key) not in self._seen:
                self.fail(str(key), "unknown field")


def _kind(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, Node):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, bool):
        return f"a boolean ({value})"
    if isinstance(value, str):
        return f"a string ({value!r})"
    return f"{type(value).__name__} ({value!r})"
