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
are resolved against the file's directory, and :func:`absolute` makes every path a worker
opens (ICD, actuator data sheets, dictionaries, prognostic models) absolute, whoever gave it:
workers of a cluster do not share the client's working directory, only (on a shared file
system) its paths.

A configuration is known to the catalog by :meth:`FleetConfig.digest`: its settings with each
file replaced by the SHA-256 of its content, so the same files named another way (relative,
absolute, through a link) give the same digest, and a dictionary rebuilt in place another.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from typing import Any

from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node, load_file
from mapr_daemon.service.config import Config, parse

KEYS = ("default", "tails")


ASSET_FILES = ("actuator", "dictionary", "prognosis")
"""The fields of an asset that name a file a worker reads."""
OUTPUTS = ("source", "catalog", "record")
"""What does not change a recording's result: where the config came from and where the
client writes (left out of the digest)."""


@dataclasses.dataclass(frozen=True)
class FleetConfig:
    """The default config and the tails that have their own."""

    default: Config
    tails: dict[str, Config] = dataclasses.field(default_factory=dict)
    _digests: dict[int, str] = dataclasses.field(default_factory=dict, init=False,
                                                 repr=False, compare=False)

    def for_tail(self, tail: str) -> Config:
        return self.tails.get(tail, self.default)

    def configs(self) -> list[Config]:
        """The default, then each tail's own."""
        return [self.default, *self.tails.values()]

    def digest(self, tail: str | None = None) -> str:
        """The content digest (:func:`content_digest`) of ``tail``'s config (None: the
        default's), computed once per config."""
        config = self.default if tail is None else self.for_tail(tail)
        known = self._digests.get(id(config))
        if known is None:
            known = self._digests[id(config)] = content_digest(config)
        return known

    def absolute(self) -> FleetConfig:
        """The same configs with every path a worker opens absolute (:func:`absolute`)."""
        return FleetConfig(absolute(self.default),
                           {tail: absolute(c) for tail, c in self.tails.items()})


def absolute(config: Config) -> Config:
    """``config`` with its ICD, its reasoner's dictionary and each asset's files as absolute
    paths (relative ones taken from the current directory, as a command line means them)."""

    def fix(path: str | None) -> str | None:
        return None if path is None else os.path.abspath(os.path.expanduser(path))

    assets = tuple(dataclasses.replace(a, actuator=fix(a.actuator) or a.actuator,
                                       dictionary=fix(a.dictionary),
                                       prognosis=fix(a.prognosis)) for a in config.assets)
    reasoner = dataclasses.replace(config.reasoner, dictionary=fix(config.reasoner.dictionary))
    return dataclasses.replace(config, icd=fix(config.icd) or config.icd, assets=assets,
                               reasoner=reasoner)


def content_digest(config: Config) -> str:
    """SHA-256 (16 hex digits) of what decides a recording's result under ``config``: its
    settings (key order aside, :data:`OUTPUTS` left out) with each file a worker reads (ICD,
    dictionaries, prognostic models, actuator data sheets) replaced by the SHA-256 of its
    bytes. A file that cannot be read is digested by its absolute path (the run reports it
    when it builds the pipeline)."""
    plain = dataclasses.asdict(config)
    for key in OUTPUTS:
        plain.pop(key)
    plain["icd"] = _file_digest(config.icd)
    plain["reasoner"]["dictionary"] = _file_digest(config.reasoner.dictionary)
    for asset in plain["assets"]:
        for key in ASSET_FILES:
            asset[key] = _file_digest(asset[key])
    text = json.dumps(plain, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _file_digest(path: Any) -> str | None:
    if path is None:
        return None
    try:
        with open(path, "rb") as handle:
            return "sha256:" + hashlib.file_digest(handle, "sha256").hexdigest()
    except OSError:
        return "path:" + os.path.abspath(str(path))


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
