"""What drives the plant over time: a :class:`Profile` (position command plus air data), and
the named steady flight conditions it is flown at.

A profile is sampled at the plant's output rate: surface position command (deg) and the air
data the air-data computer would put on the bus (altitude, true airspeed, density, dynamic
pressure). It is production code, not the simulator's: the reasoner flies the plant model
over the built-in-test profile (:mod:`mapr_daemon.ema.bit`) to build its fault dictionary,
and the daemon aligns a BIT found on the bus on the same profile's time axis. Flights for the
simulated aircraft (steady, sine, JSBSim) live in :mod:`mapr_daemon.testbed`.

Flight conditions are named in :data:`CONDITIONS`; ``ground`` has no air load.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class Condition:
    """A steady flight condition: altitude and true airspeed (ISA atmosphere)."""

    name: str
    altitude_m: float
    airspeed_mps: float

    @property
    def density_kg_m3(self) -> float:
        return isa_density(self.altitude_m)

    @property
    def dynamic_pressure_pa(self) -> float:
        return 0.5 * self.density_kg_m3 * self.airspeed_mps**2


CONDITIONS: dict[str, Condition] = {c.name: c for c in (
    Condition("ground", 0.0, 0.0),
    Condition("approach", 300.0, 33.0),
    Condition("climb", 1000.0, 40.0),
    Condition("cruise", 1500.0, 55.0),
    Condition("dash", 600.0, 62.0),
)}
"""Named conditions, chosen inside a light aircraft's envelope (c172x: stall ~24 m/s)."""


def isa_density(altitude_m: float) -> float:
    """ISA troposphere density (kg/m^3)."""
    t = 288.15 - 0.0065 * altitude_m
    return float(1.225 * (t / 288.15) ** 4.2559)


@dataclasses.dataclass(frozen=True)
class Profile:
    """Inputs over time, one value per output sample."""

    name: str
    time_s: FloatArray
    command_deg: FloatArray
    altitude_m: FloatArray
    airspeed_mps: FloatArray
    density_kg_m3: FloatArray
    dynamic_pressure_pa: FloatArray
    corners_s: tuple[float, ...] = ()

    @property
    def n_samples(self) -> int:
        return int(self.time_s.size)


def condition(name: str) -> Condition:
    """A named flight condition; ConfigError lists the known ones."""
    try:
        return CONDITIONS[name]
    except KeyError:
        raise ConfigError(f"unknown flight condition (known: {', '.join(CONDITIONS)})",
                          field="condition") from None


def steady(name: str, time_s: FloatArray, command_deg: FloatArray, cond: Condition,
           corners_s: tuple[float, ...] = ()) -> Profile:
    """A profile flown at one steady condition (the air data constant over ``time_s``)."""
    ones = np.ones(time_s.size)
    return Profile(name=name, time_s=time_s, command_deg=command_deg,
                   altitude_m=ones * cond.altitude_m, airspeed_mps=ones * cond.airspeed_mps,
                   density_kg_m3=ones * cond.density_kg_m3,
                   dynamic_pressure_pa=ones * cond.dynamic_pressure_pa, corners_s=corners_s)
