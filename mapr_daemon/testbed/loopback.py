"""The daemon's loopback testbed: the simulated aircraft flown as the config's ``testbed:``
section says, opened as a bus monitor.

A steady flight on which the flight control computer requests a built-in test every
:data:`BIT_EVERY_S` (the EMA runs the BIT motion itself, the record the reasoner decides on),
or a JSBSim flight, with an optionally seeded EMA fault, so ``mapr run`` without a config file
is the embedded demo of the real service. The daemon reaches this module only through
:mod:`mapr_daemon.daemon.source`, and only for ``backend.name: loopback``: the simulator is a
leaf that production code does not import otherwise.
Each call of the factory builds a fresh aircraft, so a reopened loopback starts a new flight.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from drivers.monitor import BusMonitor, open_monitor
from mapr_daemon.daemon.config import Config, TestbedActuator
from mapr_daemon.daemon.filler import fill_schedule
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import ActuatorParams, load_actuator, with_sample_rate
from mapr_daemon.ema.profile import Profile, condition
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import Icd
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.ema_terminal import TerminalNames
from mapr_daemon.testbed.profiles import steady_profile

RATE_HZ = 2000.0
JSBSIM_DEFAULT_S = 60.0
BIT_EVERY_S = 2.0
"""Period of the testbed's BIT requests (the BIT motion lasts 1.46 s; requests go at 1 Hz)."""


def parse_faults(text: str | None, params: ActuatorParams) -> FaultSet:
    """Faults from ``fault=...`` text, comma-separated (ConfigError if one does not parse)."""
    if text is None or text == "none":
        return FaultSet()
    return FaultSet.of(parse_fault(part.strip(), params) for part in text.split(","))


def seeded_faults(config: Config) -> FaultSet:
    """The first flown EMA's faults (``testbed.fault``, or its ``testbed.actuators`` entry)."""
    first = config.testbed.flown(config.assets)[0]
    return parse_faults(first.fault, load_actuator(first.actuator))


def block_rate_hz(icd: Icd, rt: int) -> float:
    """The sample rate of the fast block of the EMA at ``rt`` (its plant's rate); KeyError
    when the table has no EMA there."""
    fast = TerminalNames(icd, rt).messages["fast_block"]
    return RATE_HZ if fast.group is None else fast.group.sample_rate_hz


def flown_emas(config: Config, icd: Icd) -> list[tuple[TestbedActuator, ActuatorParams,
                                                         FaultSet]]:
    """Each EMA the testbed flies, its data sheet at its block rate, and its faults
    (ConfigError when a fault does not parse or the ICD has no such EMA)."""
    out = []
    for entry in config.testbed.flown(config.assets):
        params = load_actuator(entry.actuator)
        try:
            rate = block_rate_hz(icd, entry.rt)
        except KeyError as error:
            raise ConfigError(str(error.args[0]), field="testbed.actuators") from None
        out.append((entry, with_sample_rate(params, rate), parse_faults(entry.fault, params)))
    return out


def flight_profile(config: Config) -> Profile:
    tb = config.testbed
    condition(tb.condition)   # ConfigError naming the known conditions
    if tb.profile == "jsbsim":
        from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight
        return jsbsim_flight(RATE_HZ, tb.condition, duration_s=tb.duration_s or JSBSIM_DEFAULT_S,
                             seed=tb.seed)
    return steady_profile(RATE_HZ, tb.condition)


def check(config: Config) -> None:
    """Validate what opening would need, so errors surface at start (exit 78), not later."""
    seeded_faults(config)
    condition(config.testbed.condition)
    for entry in config.testbed.flown(config.assets):
        parse_faults(entry.fault, load_actuator(entry.actuator))


def testbed_factory(config: Config, icd: Icd) -> Callable[[], BusMonitor]:
    """A function that opens the simulated aircraft's loopback bus (called again after each
    failure). The EMAs are ``testbed.actuators`` (default: one, the first asset's), each at
    its fast block's sample rate, each requested a BIT every :data:`BIT_EVERY_S`."""
    options: dict[str, Any] = dict(config.backend.options)
    tb = config.testbed
    emas = flown_emas(config, icd)
    profile = flight_profile(config)

    def open_testbed() -> BusMonitor:
        bit = tb.profile == "bit"
        requests: tuple[float, ...] = (0.0,) if bit else ()
        every = BIT_EVERY_S if bit else None
        (first, params, faults), *others = emas
        aircraft = Aircraft(icd, profile, params, faults, seed=first.seed,
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
        opts = {"realtime": tb.realtime, "bit_level": tb.bit_level, "seed": tb.seed,
                **options}
        return open_monitor("loopback", terminals=terminals, schedule=schedule,
                            frames=frames, **opts)

    return open_testbed
