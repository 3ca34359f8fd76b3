"""The daemon's configuration (``configs/mapr.yaml``): loading, validation, defaults.

Every key has a default that works on the simulated aircraft (the ``testbed`` backend), so
``mapr run`` with no file is the embedded demo of the real service. A wrong key, type or
value raises :class:`~mapr_daemon.errors.ConfigError` whose ``str()`` is one line
``file:line: field: problem`` (the daemon exits 78 with it, and systemd does not restart a
config error).
Relative paths in a file are resolved against the file's directory, so a config travels with
its ICD and dictionary.

The sections the pipeline reads (``assets``, ``aircraft``, ``reasoner`` and the ICD) are its
dataclasses (:mod:`mapr_daemon.pipeline.settings`); the ``testbed:`` section is kept as
written and read by the simulator when the ``testbed`` backend opens. Checks against this
machine (files readable, directories writable) are :mod:`.preflight`'s, not parsing's.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from drivers.chapter10.tmats import SEPARATORS as TMATS_SEPARATORS
from drivers.monitor import available_backends
from mapr_daemon import TESTBED_BACKEND
from mapr_daemon.catalog import default_path as default_catalog_path
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node, load_file
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.settings import (
    DEFAULT_ICD,
    AircraftConfig,
    AssetConfig,
    ReasonerConfig,
)
from mapr_daemon.service.sections import SectionReader, read_section

LEVELS = ("debug", "info", "warning", "error")
OLD_TESTBED_NAME = "loopback"
"""What a daemon config called the simulated aircraft before it was named ``testbed``: still
read as the testbed, with a deprecation warning (a bare loopback bus carries no EMA, so the
daemon never meant the drivers' raw ``loopback`` backend by it)."""
log = logging.getLogger("mapr")


@dataclasses.dataclass(frozen=True)
class BackendConfig:
    """Which bus monitor to open, its options, and how to retry it when it fails."""

    name: str = TESTBED_BACKEND
    options: dict[str, Any] = dataclasses.field(default_factory=dict)
    retry_initial_s: float = 0.5
    retry_max_s: float = 30.0


@dataclasses.dataclass(frozen=True)
class CatalogConfig:
    path: str = dataclasses.field(default_factory=default_catalog_path)
    durability: str = "power-loss"
    stats_interval_s: float = 10.0
    episode_clear_bits: int = 3
    """Consecutive BITs without the fault that close its episode (catalog/episodes.py)."""


@dataclasses.dataclass(frozen=True)
class HealthConfig:
    """What the daemon's log says about each actuator's health (:mod:`.health_log`)."""

    rul_warn_flights: float | None = 10.0
    """A warning, once, when an actuator's RUL (the low end of its 90 % interval) falls
    below this many flights; None: never."""


@dataclasses.dataclass(frozen=True)
class RecordConfig:
    """Chapter 10 recording of every record the daemon sees (None: no recording)."""

    path: str | None = None
    """A directory; each session writes ``session-NNNNNN-YYYYmmddTHHMMSSZ.ch10`` in it."""
    channel_id: int = 1


@dataclasses.dataclass(frozen=True)
class Config:
    """The whole daemon configuration (see ``configs/mapr.yaml`` for every key)."""

    backend: BackendConfig = dataclasses.field(default_factory=BackendConfig)
    icd: str = str(DEFAULT_ICD)
    testbed: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """The ``testbed:`` section as written (its lines kept, for the simulator's errors):
    the ``testbed`` backend reads it (``mapr_daemon/testbed/config.py``)."""
    assets: tuple[AssetConfig, ...] = (AssetConfig(),)
    aircraft: AircraftConfig = dataclasses.field(default_factory=AircraftConfig)
    reasoner: ReasonerConfig = dataclasses.field(default_factory=ReasonerConfig)
    catalog: CatalogConfig = dataclasses.field(default_factory=CatalogConfig)
    record: RecordConfig = dataclasses.field(default_factory=RecordConfig)
    health: HealthConfig = dataclasses.field(default_factory=HealthConfig)
    queue_batches: int = 256
    """Bound of the queue between the bus reader and the reasoner, in record batches."""
    queue_wait_s: float = 0.5
    """How long the reader waits for room before it drops a batch and reports it."""
    status_interval_s: float = 1.0
    log_level: str = "info"
    source: str | None = None
    """The file this came from (None: built-in defaults)."""

    def digest(self) -> str:
        """SHA-256 of the settings (the catalog's ``config_hash``), independent of key order."""
        plain = dataclasses.asdict(self)
        plain.pop("source")
        text = json.dumps(plain, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def parse(raw: Any, path: str) -> Config:
    """A :class:`Config` from parsed YAML (``raw``) read from ``path``."""
    r = SectionReader(path, Path(path).resolve().parent)
    if raw is None:
        raw = Node()
        raw.line, raw.key_lines = 1, {}
    if not isinstance(raw, Node):
        raise ConfigError("the daemon config is a mapping of sections", path=path, line=1)
    top = r.mapping(raw, Config, "")
    backend = read_section(r, raw, "backend", BackendConfig, {
        "name": ("str", {"choices": tuple(available_backends())}),
        "options": ("dict", {}), "retry_initial_s": ("float", {"minimum": 0.01}),
        "retry_max_s": ("float", {"minimum": 0.01})})
    if backend.name == OLD_TESTBED_NAME:
        log.warning("%s:%d: backend.name: %r is deprecated in a daemon config, write %r "
                    "(the simulated aircraft)", path, raw.get("backend", raw).line_of("name"),
                    OLD_TESTBED_NAME, TESTBED_BACKEND)
        backend = dataclasses.replace(backend, name=TESTBED_BACKEND)
    testbed = _testbed(r, raw)
    reasoner = read_section(r, raw, "reasoner", ReasonerConfig, {
        "dictionary": ("path", {"optional": True}),
        "threshold": ("float", {"minimum": 1e-9, "optional": True}), "paper": ("bool", {}),
        "inflight": ("bool", {})})
    catalog = read_section(r, raw, "catalog", CatalogConfig, {
        "path": ("path", {}), "durability": ("str", {"choices": ("power-loss", "crash")}),
        "stats_interval_s": ("float", {"minimum": 0.1}),
        "episode_clear_bits": ("int", {"minimum": 1})})
    record = read_section(r, raw, "record", RecordConfig, {
        "path": ("path", {"optional": True}),
        "channel_id": ("int", {"minimum": 1})})
    health = read_section(r, raw, "health", HealthConfig, {
        "rul_warn_flights": ("float", {"minimum": 0.0, "optional": True})})
    aircraft = read_section(r, raw, "aircraft", AircraftConfig, {
        "tail": ("str", {}), "flight_gap_s": ("float", {"minimum": 1.0})})
    if record.path is not None and any(c in aircraft.tail for c in TMATS_SEPARATORS):
        raise r.error(raw["aircraft"], "tail", "aircraft.",
                      f"a recording (record.path) writes the tail into its TMATS record, "
                      f"which cannot hold ';' or a line break: {aircraft.tail!r}")
    kwargs: dict[str, Any] = {"backend": backend, "testbed": testbed, "reasoner": reasoner,
                              "catalog": catalog, "record": record, "aircraft": aircraft,
                              "health": health,
                              "source": path}
    scalars: dict[str, tuple[str, dict[str, Any]]] = {
        "icd": ("path", {}), "queue_batches": ("int", {"minimum": 1}),
        "queue_wait_s": ("float", {"minimum": 0.0}),
        "status_interval_s": ("float", {"minimum": 0.05}),
        "log_level": ("str", {"choices": LEVELS})}
    for name, (kind, opts) in scalars.items():
        if name in top:
            kwargs[name] = r.value(raw, name, "", top[name], kind, **opts)
    if "assets" in top:
        kwargs["assets"] = _assets(r, raw, top["assets"])
    config = Config(**kwargs)
    if config.backend.retry_max_s < config.backend.retry_initial_s:
        backend_node = raw.get("backend")
        where = backend_node if isinstance(backend_node, Node) else raw
        raise r.error(where, "retry_max_s", "backend.", "must be >= retry_initial_s")
    return config


def _testbed(r: SectionReader, root: Node) -> Mapping[str, Any]:
    """``testbed:`` as written (a mapping; absent: empty), for the simulator to read."""
    node = root.get("testbed")
    if node is None:
        return {}
    if not isinstance(node, Node):
        raise ConfigError("expected a mapping", path=r.path, line=root.line_of("testbed"),
                          field="testbed")
    return node


def _assets(r: SectionReader, root: Node, value: Any) -> tuple[AssetConfig, ...]:
    if not isinstance(value, list) or not value:
        raise r.error(root, "assets", "", "expected a non-empty list of {name, rt}")
    out = []
    for i, item in enumerate(value):
        prefix = f"assets[{i}]."
        raw = r.mapping(item, AssetConfig, prefix, root, "assets")
        assert isinstance(item, Node)
        name = r.value(item, "name", prefix, raw.get("name", "EMA1"), "str")
        rt = r.value(item, "rt", prefix, raw.get("rt", 5), "int", minimum=0)
        if rt > 30:
            raise r.error(item, "rt", prefix, f"a remote-terminal address is 0..30, got {rt}")
        extra: dict[str, Any] = {}
        if "actuator" in raw:
            extra["actuator"] = r.value(item, "actuator", prefix, raw["actuator"], "path")
        if "signals" in raw:
            extra["signals"] = _signals(r, item, prefix, raw["signals"])
        for key in ("dictionary", "prognosis", "commissioned"):
            if key in raw:
                extra[key] = r.value(item, key, prefix, raw[key], "path", optional=True)
        if "expected_life_flights" in raw:
            extra["expected_life_flights"] = _lives(r, item, prefix,
                                                    raw["expected_life_flights"])
        out.append(AssetConfig(name=name, rt=rt, **extra))
    return tuple(out)


def _signals(r: SectionReader, item: Node, prefix: str, value: Any) -> dict[str, str]:
    """``assets[i].signals``: a whole ICD-signal -> reasoner-channel mapping
    (:mod:`~mapr_daemon.pipeline.wiring`)."""
    if not isinstance(value, Node):
        raise r.error(item, "signals", prefix, "expected a mapping of ICD signal -> channel")
    out: dict[str, str] = {}
    for signal, channel in value.items():
        if not isinstance(channel, str):
            raise r.error(value, str(signal), f"{prefix}signals.",
                          f"expected a channel name, got {channel!r}")
        out[str(signal)] = channel
    for signal, problem in wiring.problems(out):
        if signal is None:
            raise r.error(item, "signals", prefix, problem)
        raise r.error(value, signal, f"{prefix}signals.", problem)
    return out


def _lives(r: SectionReader, item: Node, prefix: str, value: Any) -> dict[str, float]:
    """``assets[i].expected_life_flights``: aging kind -> expected life in flights (> 0)."""
    from mapr_daemon.ema.degradation import FAILURE  # the aging kinds; numpy only when used

    if not isinstance(value, Node):
        raise r.error(item, "expected_life_flights", prefix,
                      "expected a mapping of aging kind -> flights")
    out: dict[str, float] = {}
    for kind, flights in value.items():
        if str(kind) not in FAILURE:
            raise r.error(value, str(kind), f"{prefix}expected_life_flights.",
                          f"not an aging kind (known: {', '.join(sorted(FAILURE))})")
        out[str(kind)] = r.value(value, str(kind), f"{prefix}expected_life_flights.", flights,
                                 "float", minimum=1.0)
    return out


def load_config(path: str | os.PathLike[str] | None) -> Config:
    """The configuration in ``path`` (None: the built-in defaults). Raises ConfigError."""
    if path is None:
        return Config()
    text_path = os.fspath(path)
    return parse(read(text_path), text_path)


def read(text_path: str) -> Any:
    """The parsed YAML of the config file ``text_path`` (mappings carry their lines);
    ConfigError naming the file when it cannot be read or is not YAML."""
    try:
        raw = load_file(text_path)
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=text_path) from None
    except ConfigError as error:   # YAML syntax: already file:line
        raise ConfigError(error.detail, path=text_path, line=error.line) from None
    return raw
