"""A fleet's configuration: each tail's actuator, ICD and dictionary, set once.

::

    default:                 # a daemon config (configs/mapr.yaml's icd, assets, reasoner)
      icd: icd/ema-testbed.yaml
      assets: [{name: EMA1, rt: 5, actuator: actuators/aileron-uav.yaml}]
      reasoner: {dictionary: dictionary.npz}
    tails:
      N102:                  # a tail whose aircraft differs: its own config, whole
        assets: [{name: EMA1, rt: 7, actuator: actuators/elevator-uav.yaml}]
        reasoner: {dictionary: elevator.npz}

Each section is read by the daemon's own parser (:func:`mapr_daemon.service.config.parse`),
so every key, default and check is the daemon's and an error names ``file:line: field``. A
tail's section replaces the default for that tail (it does not merge with it). Relative paths
are resolved against the file's directory; workers of a cluster must see the same paths.
"""

from __future__ import annotations

import dataclasses
import os

from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node, load_file
from mapr_daemon.service.config import Config, parse

KEYS = ("default", "tails")


@dataclasses.dataclass(frozen=True)
class FleetConfig:
    """The default config and the tails that have their own."""

    default: Config
    tails: dict[str, Config] = dataclasses.field(default_factory=dict)

    def for_tail(self, tail: str) -> Config:
        return self.tails.get(tail, self.default)


def load_fleet_config(path: str | os.PathLike[str]) -> FleetConfig:
    """The fleet config in ``path``; ConfigError (``file:line: field: problem``) if wrong."""
    name = os.fspath(path)
    try:
        raw = load_file(name)
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=name) from None
    except ConfigError as error:
        raise ConfigError(error.detail, path=name, line=error.line) from None
    if raw is None:
        raw = Node()
        raw.line, raw.key_lines = 1, {}
    if not isinstance(raw, Node):
        raise ConfigError("a fleet config is a mapping with default: and tails:", path=name,
                          line=1)
    for key in raw:
        if key not in KEYS:
            raise ConfigError(f"unknown key (known: {', '.join(KEYS)})", path=name,
                              line=raw.line_of(str(key)), field=str(key))
    default = parse(raw.get("default"), name)
    tails_node = raw.get("tails")
    tails: dict[str, Config] = {}
    if tails_node is not None:
        if not isinstance(tails_node, Node):
            raise ConfigError("expected a mapping of tail number -> config", path=name,
                              line=raw.line_of("tails"), field="tails")
        for tail, section in tails_node.items():
            if not isinstance(section, Node):
                raise ConfigError("expected a daemon config mapping", path=name,
                                  line=tails_node.line_of(str(tail)), field=f"tails.{tail}")
            tails[str(tail)] = parse(section, name)
    return FleetConfig(default, tails)
