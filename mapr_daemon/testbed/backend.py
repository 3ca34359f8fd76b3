"""The ``testbed`` bus-monitor backend: the simulated aircraft on the loopback bus.

Registered by name in the drivers' backend registry (:mod:`mapr_daemon`'s import does it,
without importing this module), so the daemon opens it as it opens any backend, with
``open_monitor("testbed", testbed=..., config_file=..., icd=..., assets=...)``: the daemon
config's ``testbed:`` section as written (read here, :mod:`.config`), the file it is in, its
ICD and its ``assets:``. That is how ``mapr run`` without a config
file is the embedded demo of the real service, and no production module imports the
simulator.

The flight: a steady one on which the flight control computer requests a built-in test of
each EMA every :data:`BIT_EVERY_S` (the EMA runs the BIT motion itself, the record the
reasoner decides on), or a JSBSim flight. The EMAs: ``testbed.actuators`` (each its name,
RT, actuator file, fault and seed), or by default one, the first asset's, with
``testbed.fault`` and ``testbed.seed``; each EMA's plant runs at its fast block's sample
rate in the ICD. Each opening builds a fresh aircraft, so a reopened backend starts a new
flight.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

from drivers.backends.loopback import LoopbackMonitor
from drivers.monitor import MonitorFilter
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import ActuatorParams, load_actuator, with_sample_rate
from mapr_daemon.ema.profile import Profile, condition
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import Icd, load_icd
from mapr_daemon.icd.yamlsrc import Node
from mapr_daemon.pipeline.settings import DEFAULT_ICD, AssetConfig
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.config import TestbedActuator, TestbedConfig, parse_section
from mapr_daemon.testbed.ema_terminal import TerminalNames
from mapr_daemon.testbed.filler import fill_schedule
from mapr_daemon.testbed.profiles import steady_profile

RATE_HZ = 2000.0
"""The flight profile's rate (and an EMA's, if its fast block has no group)."""
JSBSIM_DEFAULT_S = 60.0
BIT_EVERY_S = 2.0
"""Period of the testbed's BIT requests (the BIT motion lasts 1.46 s; requests go at 1 Hz)."""

Flown = tuple[TestbedActuator, ActuatorParams, FaultSet]


def testbed_config(testbed: TestbedConfig | Mapping[str, Any] | None,
                   config_file: str | None = None) -> TestbedConfig:
    """The ``testbed:`` section: as read from the daemon config ``config_file`` (checked key
    by key, errors ``file:line: field: problem``), or its dataclass or plain-dict form."""
    if testbed is None:
        return TestbedConfig()
    if isinstance(testbed, TestbedConfig):
        return testbed
    if isinstance(testbed, Node):
        return parse_section(testbed, config_file)
    if not isinstance(testbed, Mapping):
        raise ConfigError(f"testbed options: expected a mapping, got {testbed!r}",
                          field="testbed")
    fields = dict(testbed)
    entries = fields.pop("actuators", ()) or ()
    try:
        actuators = tuple(a if isinstance(a, TestbedActuator) else TestbedActuator(**a)
                          for a in entries)
        return TestbedConfig(**fields, actuators=actuators)
    except TypeError as error:
        raise ConfigError(f"testbed options: {error}", field="testbed") from None


SECTION_KEYS = frozenset(f.name for f in dataclasses.fields(TestbedConfig)) - {
    "realtime", "bit_level", "seed"}
"""Keys of the ``testbed:`` section that may also be given as options of their own
(``mapr monitor --backend testbed -O duration_s=1``); the three left out are the loopback
bus's options too, and go to it."""


def section(testbed: TestbedConfig | Mapping[str, Any] | None,
            options: dict[str, Any]) -> TestbedConfig:
    """The section, with any of its keys given as options of their own (taken out of
    ``options``) overriding it; ``options``' ``config_file`` (taken out too) is the daemon
    config the section was read from."""
    flat = {k: options.pop(k) for k in list(options) if k in SECTION_KEYS}
    base = testbed_config(testbed, options.pop("config_file", None))
    if not flat:
        return base
    return testbed_config({**dataclasses.asdict(base), **flat})


def asset_configs(assets: Sequence[AssetConfig | Mapping[str, Any]] | None
                  ) -> tuple[AssetConfig, ...]:
    """The daemon's ``assets:`` (dataclasses or plain dicts; default: the one EMA1)."""
    if not assets:
        return (AssetConfig(),)
    keep = {f.name for f in dataclasses.fields(AssetConfig)}
    return tuple(a if isinstance(a, AssetConfig) else
                 AssetConfig(**{k: v for k, v in a.items() if k in keep}) for a in assets)


def parse_faults(text: str | None, params: ActuatorParams) -> FaultSet:
    """Faults from ``fault=...`` text, comma-separated (ConfigError if one does not parse)."""
    if text is None or text == "none":
        return FaultSet()
    return FaultSet.of(parse_fault(part.strip(), params) for part in text.split(","))


def block_rate_hz(icd: Icd, rt: int) -> float:
    """The sample rate of the fast block of the EMA at ``rt`` (its plant's rate); KeyError
    when the table has no EMA there."""
    fast = TerminalNames(icd, rt).messages["fast_block"]
    return RATE_HZ if fast.group is None else fast.group.sample_rate_hz


def flown_emas(tb: TestbedConfig, assets: tuple[AssetConfig, ...], icd: Icd) -> list[Flown]:
    """Each EMA the testbed flies, its data sheet at its block rate, and its faults
    (ConfigError when a fault does not parse or the ICD has no such EMA)."""
    out = []
    for entry in tb.flown(assets):
        params = load_actuator(entry.actuator)
        try:
            rate = block_rate_hz(icd, entry.rt)
        except KeyError as error:
            raise ConfigError(str(error.args[0]), field="testbed.actuators") from None
        out.append((entry, with_sample_rate(params, rate), parse_faults(entry.fault, params)))
    return out


def flight_profile(tb: TestbedConfig) -> Profile:
    condition(tb.condition)   # ConfigError naming the known conditions
    if tb.profile == "jsbsim":
        from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight
        return jsbsim_flight(RATE_HZ, tb.condition, duration_s=tb.duration_s or JSBSIM_DEFAULT_S,
                             seed=tb.seed)
    return steady_profile(RATE_HZ, tb.condition)


def _icd(icd: Icd | str | None) -> Icd:
    """The table given (an Icd or a path), default the shipped single-EMA testbed's."""
    if icd is None:
        return load_icd(DEFAULT_ICD)
    return icd if isinstance(icd, Icd) else load_icd(icd)


class TestbedMonitor(LoopbackMonitor):
    """A loopback bus with the simulated aircraft on it.

    Options: ``testbed`` (the daemon config's ``testbed:`` section, as read from the file
    named by ``config_file``, as its dataclass or as a dict), ``icd`` (an
    :class:`~mapr_daemon.icd.Icd` or a path; default the shipped
    ``configs/icd/ema-testbed.yaml``), ``assets`` (the config's ``assets:``, for the
    single-EMA default); any other option goes to
    :class:`~drivers.backends.loopback.LoopbackMonitor` and overrides the section's
    ``realtime``, ``bit_level`` and ``seed``. The section's other keys may also be given
    as options of their own (:data:`SECTION_KEYS`), which override it.
    """

    __test__ = False

    def __init__(self, *, testbed: TestbedConfig | Mapping[str, Any] | None = None,
                 icd: Icd | str | None = None,
                 assets: Sequence[AssetConfig | Mapping[str, Any]] | None = None,
                 filters: Sequence[MonitorFilter] | None = None, **options: Any) -> None:
        tb = section(testbed, options)
        table = _icd(icd)
        (first, params, faults), *others = flown_emas(tb, asset_configs(assets), table)
        bit = tb.profile == "bit"
        requests: tuple[float, ...] = (0.0,) if bit else ()
        every = BIT_EVERY_S if bit else None
        aircraft = Aircraft(table, flight_profile(tb), params, faults, seed=first.seed,
                            bit_requests_s=requests, bit_every_s=every, rt=first.rt)
        for entry, more_params, more_faults in others:
            aircraft.add_ema(entry.rt, more_params, more_faults, seed=entry.seed,
                             bit_requests_s=requests, bit_every_s=every)
        schedule = aircraft.schedule()
        terminals = list(aircraft.terminals())
        if tb.fill_bus:
            schedule, spare = fill_schedule(schedule, {t.address for t in terminals})
            terminals.append(spare)
        frames = None if tb.duration_s is None else round(tb.duration_s * 1e9 /
                                                          schedule.frame_ns)
        self.aircraft = aircraft
        """The simulated aircraft (its EMAs, their plants and BIT state)."""
        super().__init__(filters=filters, terminals=terminals, schedule=schedule,
                         frames=frames, **{"realtime": tb.realtime, "bit_level": tb.bit_level,
                                           "seed": tb.seed, **options})

    @classmethod
    def check_options(cls, **config: Any) -> None:
        """What opening needs, checked without flying: the section, every EMA in the ICD,
        every fault, the flight condition (ConfigError)."""
        options = dict(config)
        tb = section(options.pop("testbed", None), options)
        flown_emas(tb, asset_configs(config.get("assets")), _icd(config.get("icd")))
        condition(tb.condition)
