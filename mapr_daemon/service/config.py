"""The daemon's configuration (``configs/mapr.yaml``): loading, validation, defaults.

Every key has a default that works on the loopback testbed, so ``mapr run`` with no file is
the embedded demo of the real service. A wrong key, type or value raises
:class:`~mapr_daemon.errors.ConfigError` whose ``str()`` is one line ``file:line: field:
problem`` (the daemon exits 78 with it, and systemd does not restart a config error).
Relative paths in a file are resolved against the file's directory, so a config travels with
its ICD and dictionary.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

from drivers.chapter10.tmats import SEPARATORS as TMATS_SEPARATORS
from drivers.monitor import available_backends
from mapr_daemon.catalog import default_path as default_catalog_path
from mapr_daemon.ema.params import default_actuator_path
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import Node, load_file
from mapr_daemon.pipeline import wiring
from mapr_daemon.service.preflight import check as preflight_check

REPO_CONFIGS = Path(__file__).resolve().parents[2] / "configs"
"""``configs/`` of a source checkout (the default ICD lives there)."""
DEFAULT_ICD = REPO_CONFIGS / "icd" / "ema-testbed.yaml"
LEVELS = ("debug", "info", "warning", "error")
PROFILES = ("bit", "jsbsim")


@dataclasses.dataclass(frozen=True)
class BackendConfig:
    """Which bus monitor to open, its options, and how to retry it when it fails."""

    name: str = "loopback"
    options: dict[str, Any] = dataclasses.field(default_factory=dict)
    retry_initial_s: float = 0.5
    retry_max_s: float = 30.0


@dataclasses.dataclass(frozen=True)
class TestbedActuator:
    """One EMA the simulated aircraft flies (``testbed.actuators[]``)."""

    __test__ = False

    name: str
    rt: int
    actuator: str
    """Its actuator file; the plant runs at the rate of its fast block in the ICD."""
    fault: str | None = None
    """An EMA fault to seed on this actuator (None: healthy)."""
    seed: int = 1


@dataclasses.dataclass(frozen=True)
class TestbedConfig:
    """The simulated aircraft flown on the ``loopback`` backend (ignored by other backends)."""

    __test__ = False   # not a pytest test class, despite the name

    profile: str = "bit"
    """``bit``: the built-in-test motion the reasoner decides on; ``jsbsim``: a c172x flight."""
    condition: str = "cruise"
    duration_s: float | None = None
    """Bus time to run (None: for ever; the profile's last command is held after its end)."""
    fault: str | None = None
    """An EMA fault to seed (``friction@0.8``, ``open=A_high``; None: healthy)."""
    seed: int = 1
    realtime: bool = True
    bit_level: bool = False
    fill_bus: bool = False
    """Add filler transfers to a spare RT so the bus is loaded to ~100 % (a load test)."""
    actuators: tuple[TestbedActuator, ...] = ()
    """The EMAs flown on one bus, each with its own fault and seed; empty: one, the first
    asset's (name, RT, actuator file), with ``fault`` and ``seed`` above."""

    def flown(self, assets: tuple[AssetConfig, ...]) -> tuple[TestbedActuator, ...]:
        """The EMAs this testbed flies: :attr:`actuators`, or the single-EMA default."""
        if self.actuators:
            return self.actuators
        first = assets[0]
        return (TestbedActuator(first.name, first.rt, first.actuator, self.fault, self.seed),)


@dataclasses.dataclass(frozen=True)
class AssetConfig:
    """An actuator the reasoner watches: its catalog name, remote-terminal address, data
    sheet, and which ICD signal is which reasoner channel (:mod:`.wiring`)."""

    name: str = "EMA1"
    rt: int = 5
    actuator: str = dataclasses.field(default_factory=lambda: str(default_actuator_path()))
    """The actuator file (``configs/actuators/*.yaml``): its physics and its ``bit:`` motion."""
    signals: dict[str, str] = dataclasses.field(
        default_factory=lambda: dict(wiring.DEFAULT_SIGNALS))
    """ICD signal -> reasoner channel or role (default: the shipped testbed ICD's wiring)."""
    dictionary: str | None = None
    """This actuator's fault dictionary (None: ``reasoner.dictionary``, the one for all)."""
    prognosis: str | None = None
    """Its prognostic model (``mapr dictionary build --prognosis``; None: no SoH trend or
    RUL, the events say why)."""
    expected_life_flights: dict[str, float] = dataclasses.field(default_factory=dict)
    """Per aging kind, the life the fleet's parts are expected to reach, in flights (the
    user's reliability figure; the trend holds it loosely). Absent: the prognostic model's
    own, which is the aging model's assumption (200 flights)."""


@dataclasses.dataclass(frozen=True)
class AircraftConfig:
    """The aircraft the bus belongs to, and how its flights are told apart."""

    tail: str = ""
    """Tail number (empty: one aircraft, unnamed); keys flights in the catalog."""
    flight_gap_s: float = 900.0
    """Actuator traffic that resumes after at least this long starts a new flight."""


@dataclasses.dataclass(frozen=True)
class ReasonerConfig:
    """The fault dictionary (None: monitor only, no diagnosis) and decision settings."""

    dictionary: str | None = None
    threshold: float | None = None
    """Anomaly threshold override (None: the dictionary's own calibration)."""
    paper: bool = False


@dataclasses.dataclass(frozen=True)
class CatalogConfig:
    path: str = dataclasses.field(default_factory=default_catalog_path)
    durability: str = "power-loss"
    stats_interval_s: float = 10.0
    episode_clear_bits: int = 3
    """Consecutive BITs without the fault that close its episode (catalog/episodes.py)."""


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
    testbed: TestbedConfig = dataclasses.field(default_factory=TestbedConfig)
    assets: tuple[AssetConfig, ...] = (AssetConfig(),)
    aircraft: AircraftConfig = dataclasses.field(default_factory=AircraftConfig)
    reasoner: ReasonerConfig = dataclasses.field(default_factory=ReasonerConfig)
    catalog: CatalogConfig = dataclasses.field(default_factory=CatalogConfig)
    record: RecordConfig = dataclasses.field(default_factory=RecordConfig)
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


class _Reader:
    """Checks one YAML mapping against a dataclass, naming file:line:field on any error."""

    def __init__(self, path: str, base: Path) -> None:
        self.path = path
        self.base = base

    def error(self, node: Node, key: str, prefix: str, message: str) -> ConfigError:
        return ConfigError(message, path=self.path, line=node.line_of(key),
                           field=f"{prefix}{key}")

    def mapping(self, node: Any, cls: type[Any], prefix: str, parent: Node | None = None,
                key: str = "") -> dict[str, Any]:
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


def _section(r: _Reader, root: Node, key: str, cls: type[Any],
             spec: dict[str, tuple[str, dict[str, Any]]]) -> Any:
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


def parse(raw: Any, path: str, *, preflight: bool = False) -> Config:
    """A :class:`Config` from parsed YAML (``raw``) read from ``path``; with ``preflight``,
    also checked against this machine (:mod:`.preflight`: the files the daemon will open)."""
    r = _Reader(path, Path(path).resolve().parent)
    if raw is None:
        raw = Node()
        raw.line, raw.key_lines = 1, {}
    if not isinstance(raw, Node):
        raise ConfigError("the daemon config is a mapping of sections", path=path, line=1)
    top = r.mapping(raw, Config, "")
    backend = _section(r, raw, "backend", BackendConfig, {
        "name": ("str", {"choices": tuple(available_backends())}),
        "options": ("dict", {}), "retry_initial_s": ("float", {"minimum": 0.01}),
        "retry_max_s": ("float", {"minimum": 0.01})})
    testbed_node = raw.get("testbed")
    actuators = _testbed_actuators(r, testbed_node)
    testbed = _section(r, raw, "testbed", TestbedConfig, {
        "actuators": ("skip", {}),
        "profile": ("str", {"choices": PROFILES}), "condition": ("str", {}),
        "duration_s": ("float", {"minimum": 0.01, "optional": True}),
        "fault": ("str", {"optional": True}), "seed": ("int", {"minimum": 0}),
        "realtime": ("bool", {}), "bit_level": ("bool", {}), "fill_bus": ("bool", {})})
    if actuators:
        testbed = dataclasses.replace(testbed, actuators=actuators)
    reasoner = _section(r, raw, "reasoner", ReasonerConfig, {
        "dictionary": ("path", {"optional": True}),
        "threshold": ("float", {"minimum": 1e-9, "optional": True}), "paper": ("bool", {})})
    catalog = _section(r, raw, "catalog", CatalogConfig, {
        "path": ("path", {}), "durability": ("str", {"choices": ("power-loss", "crash")}),
        "stats_interval_s": ("float", {"minimum": 0.1}),
        "episode_clear_bits": ("int", {"minimum": 1})})
    record = _section(r, raw, "record", RecordConfig, {
        "path": ("path", {"optional": True}),
        "channel_id": ("int", {"minimum": 1})})
    aircraft = _section(r, raw, "aircraft", AircraftConfig, {
        "tail": ("str", {}), "flight_gap_s": ("float", {"minimum": 1.0})})
    if record.path is not None and any(c in aircraft.tail for c in TMATS_SEPARATORS):
        raise r.error(raw["aircraft"], "tail", "aircraft.",
                      f"a recording (record.path) writes the tail into its TMATS record, "
                      f"which cannot hold ';' or a line break: {aircraft.tail!r}")
    kwargs: dict[str, Any] = {"backend": backend, "testbed": testbed, "reasoner": reasoner,
                              "catalog": catalog, "record": record, "aircraft": aircraft,
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
    if preflight:
        preflight_check(config, raw, path)
    return config


def _assets(r: _Reader, root: Node, value: Any) -> tuple[AssetConfig, ...]:
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
        for key in ("dictionary", "prognosis"):
            if key in raw:
                extra[key] = r.value(item, key, prefix, raw[key], "path", optional=True)
        if "expected_life_flights" in raw:
            extra["expected_life_flights"] = _lives(r, item, prefix,
                                                    raw["expected_life_flights"])
        out.append(AssetConfig(name=name, rt=rt, **extra))
    return tuple(out)


def _testbed_actuators(r: _Reader, node: Any) -> tuple[TestbedActuator, ...]:
    """``testbed.actuators``: the EMAs flown, each {name, rt, actuator, fault, seed}."""
    if not isinstance(node, Node) or "actuators" not in node:
        return ()
    value = node.get("actuators")
    if not isinstance(value, list) or not value:
        raise r.error(node, "actuators", "testbed.",
                      "expected a non-empty list of {name, rt, actuator, fault, seed}")
    out: list[TestbedActuator] = []
    for i, item in enumerate(value):
        prefix = f"testbed.actuators[{i}]."
        raw = r.mapping(item, TestbedActuator, prefix, node, "actuators")
        assert isinstance(item, Node)
        for key in ("name", "rt", "actuator"):
            if key not in raw:
                raise r.error(item, key, prefix, "missing")
        rt = r.value(item, "rt", prefix, raw["rt"], "int", minimum=0)
        if rt > 30 or any(a.rt == rt for a in out):
            raise r.error(item, "rt", prefix, f"expected a free RT address 0..30, got {rt}")
        out.append(TestbedActuator(
            name=r.value(item, "name", prefix, raw["name"], "str"), rt=rt,
            actuator=r.value(item, "actuator", prefix, raw["actuator"], "path"),
            fault=r.value(item, "fault", prefix, raw.get("fault"), "str", optional=True),
            seed=r.value(item, "seed", prefix, raw.get("seed", 1), "int", minimum=0)))
    return tuple(out)


def _signals(r: _Reader, item: Node, prefix: str, value: Any) -> dict[str, str]:
    """``assets[i].signals``: a whole ICD-signal -> reasoner-channel mapping (:mod:`.wiring`)."""
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


def _lives(r: _Reader, item: Node, prefix: str, value: Any) -> dict[str, float]:
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


def load_config(path: str | os.PathLike[str] | None, *, preflight: bool = False) -> Config:
    """The configuration in ``path`` (None: the built-in defaults). Raises ConfigError.
    ``preflight``: also check what the daemon will meet here (``mapr run`` and its
    ``--check``: input files readable, output paths usable)."""
    if path is None:
        return Config()
    text_path = os.fspath(path)
    try:
        raw = load_file(text_path)
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=text_path) from None
    except ConfigError as error:   # YAML syntax: already file:line
        raise ConfigError(error.detail, path=text_path, line=error.line) from None
    return parse(raw, text_path, preflight=preflight)
