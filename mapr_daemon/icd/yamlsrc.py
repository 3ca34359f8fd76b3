"""YAML loading that remembers where everything came from, so errors can name file:line.

Mappings load as :class:`Node` (a ``dict``) that knows its own line and the line of each key.
Line numbers are 1-based, as editors show them.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from mapr_daemon.errors import IcdError


class Node(dict[Any, Any]):
    """A YAML mapping with the line it starts on and the line of each of its keys."""

    line: int
    key_lines: dict[str, int]

    def line_of(self, key: str) -> int:
        """The line of ``key`` in this mapping, or of the mapping itself if the key is absent."""
        return self.key_lines.get(key, self.line)


class _LineLoader(yaml.SafeLoader):
    """A SafeLoader whose mappings are :class:`Node` objects carrying line numbers.

    Booleans are YAML 1.2's ``true``/``false`` only: in YAML 1.1 an enumeration label such as
    ``OFF`` or ``NO`` would silently turn into a boolean. Floats also take YAML 1.2's
    exponent forms (``1e7``), which YAML 1.1 would read as strings.
    """


_BOOL_TAG = "tag:yaml.org,2002:bool"
_LineLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag != _BOOL_TAG]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_LineLoader.add_implicit_resolver(
    _BOOL_TAG, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
_LineLoader.add_implicit_resolver(   # YAML 1.2 floats too: 1e7, 2.5E-3 (1.1 wants 1.0e+7)
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"), list("-+0123456789"))


def _construct_node(loader: _LineLoader, node: yaml.MappingNode) -> Node:
    loader.flatten_mapping(node)
    out = Node()
    out.line = node.start_mark.line + 1
    out.key_lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if not isinstance(key, (str, int)):
            raise yaml.constructor.ConstructorError(
                None, None, f"mapping key {key!r} is not a name or a number", key_node.start_mark)
        if key in out:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[str(key)] = key_node.start_mark.line + 1
    return out


_LineLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_node)

_FastLoader: type[Any] = _LineLoader
if getattr(yaml, "__with_libyaml__", False):
    from yaml._yaml import CParser

    class _CLineLoader(CParser, _LineLoader):
        """:class:`_LineLoader` on libyaml's parser (several times faster; the same nodes,
        marks and resolvers, the constructors above). Used when PyYAML has libyaml."""

        def __init__(self, stream: str) -> None:
            CParser.__init__(self, stream)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)

    _FastLoader = _CLineLoader


def load_text(text: str, path: str) -> Any:
    """Parse YAML ``text``; a syntax error becomes an :class:`IcdError` naming ``path:line``."""
    if _FastLoader is not _LineLoader:
        try:
            return yaml.load(text, Loader=_FastLoader)  # a SafeLoader subclass
        except yaml.YAMLError:
            pass  # the error as the pure-Python parser words it, below
    try:
        return yaml.load(text, Loader=_LineLoader)  # a SafeLoader subclass
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = error.problem or error.context or "invalid YAML"
        raise IcdError(f"invalid YAML: {problem}", path=path, line=line) from None
    except yaml.YAMLError as error:
        raise IcdError(f"invalid YAML: {error}", path=path) from None


def load_file(path: str | Path) -> Any:
    """Read and parse a YAML file (``OSError`` if it cannot be read)."""
    text = Path(path).read_text(encoding="utf-8")
    return load_text(text, str(path))
