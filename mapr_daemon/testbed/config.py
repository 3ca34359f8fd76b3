"""The daemon config's ``testbed:`` section: the simulated aircraft, read by the simulator.

The daemon's config (:mod:`mapr_daemon.service.config`) keeps the section as written (a
mapping carrying its lines) and passes it to the ``testbed`` backend with the config file's
name; :func:`parse_section` reads it here, so the service knows nothing of the simulator's
settings, and a wrong key, type or value is the same one-line ``file:line: field: problem``
:class:`~mapr_daemon.errors.ConfigError` (exit 78) as anywhere else in the file. Relative
actuator paths resolve against the config file's directory.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mapr_daemon.icd.yamlsrc import Node
from mapr_daemon.pipeline.settings import AssetConfig
from mapr_daemon.service.sections import SectionReader, read_section

PROFILES = ("bit", "jsbsim")


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
    """The simulated aircraft flown on the ``testbed`` backend (ignored by other backends)."""

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


def parse_section(node: Mapping[str, Any], path: str | None) -> TestbedConfig:
    """The ``testbed:`` section ``node`` of the config file ``path`` (a mapping as the file's
    loader gives it, with its lines), checked key by key."""
    name = path or "<config>"
    r = SectionReader(name, Path(name).resolve().parent)
    root = Node({"testbed": node})
    root.line, root.key_lines = getattr(node, "line", 1), {}
    testbed_node = root.get("testbed")
    actuators = _testbed_actuators(r, testbed_node)
    testbed: TestbedConfig = read_section(r, root, "testbed", TestbedConfig, {
        "actuators": ("skip", {}),
        "profile": ("str", {"choices": PROFILES}), "condition": ("str", {}),
        "duration_s": ("float", {"minimum": 0.01, "optional": True}),
        "fault": ("str", {"optional": True}), "seed": ("int", {"minimum": 0}),
        "realtime": ("bool", {}), "bit_level": ("bool", {}), "fill_bus": ("bool", {})})
    if actuators:
        testbed = dataclasses.replace(testbed, actuators=actuators)
    return testbed


def _testbed_actuators(r: SectionReader, node: Any) -> tuple[TestbedActuator, ...]:
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
