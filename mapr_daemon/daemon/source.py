"""What the daemon opens: the configured backend, or the simulated aircraft on the loopback.

For ``backend.name: loopback`` the bus is the testbed aircraft (:mod:`mapr_daemon.testbed`)
flying the configured profile — a steady flight on which the flight control computer
requests a built-in test every :data:`BIT_EVERY_S` (the EMA runs the BIT motion itself, the
record the reasoner decides on), or a JSBSim flight — with an optionally seeded EMA fault,
so ``mapr run`` without a config file is the embedded demo of the real service. Every other
backend gets ``backend.options`` as is.
Each call builds a fresh aircraft, so a reopened loopback starts a new flight.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from drivers.monitor import BusMonitor, open_monitor
from mapr_daemon.daemon.config import Config
from mapr_daemon.daemon.filler import fill_schedule
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import Icd
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import Profile, condition, steady_profile

RATE_HZ = 2000.0
JSBSIM_DEFAULT_S = 60.0
BIT_EVERY_S = 2.0
"""Period of the testbed's BIT requests (the BIT motion lasts 1.46 s; requests go at 1 Hz)."""


def seeded_faults(text: str | None) -> FaultSet:
    """The testbed's fault from ``testbed.fault`` (ConfigError if it does not parse)."""
    if text is None or text == "none":
        return FaultSet()
    params = load_actuator(default_actuator_path())
    return FaultSet.of(parse_fault(part.strip(), params) for part in text.split(","))


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
    if config.backend.name == "loopback":
        seeded_faults(config.testbed.fault)
        condition(config.testbed.condition)


def monitor_factory(config: Config, icd: Icd) -> Callable[[], BusMonitor]:
    """A function that opens the configured monitor (called again after each failure)."""
    options: dict[str, Any] = dict(config.backend.options)
    if config.backend.name != "loopback":
        return lambda: open_monitor(config.backend.name, **options)
    tb = config.testbed
    faults = seeded_faults(tb.fault)
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE_HZ)
    profile = flight_profile(config)

    def open_testbed() -> BusMonitor:
        bit = tb.profile == "bit"
        aircraft = Aircraft(icd, profile, params, faults, seed=tb.seed,
                            bit_requests_s=(0.0,) if bit else (),
                            bit_every_s=BIT_EVERY_S if bit else None)
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
