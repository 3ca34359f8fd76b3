"""Motion and flight profiles that drive the EMA plant: position command plus air data.

A :class:`Profile` is sampled at the plant's output rate: surface position command (deg) and
the air data the air-data computer would put on the bus (altitude, true airspeed, density,
dynamic pressure). Two sources:

* :func:`bit_profile` — the built-in-test motion of the paper's Figure 16: a trapezoidal
  position command with four corners (start and end of the ramp up, start and end of the
  ramp down), fast enough that the drive runs into its voltage and current limits at the
  corners, held long enough for the response to settle. Flown at a named flight condition
  (dynamic pressure) or on the ground (no air load).
* :func:`mapr_daemon.testbed.flight.jsbsim_flight` — a JSBSim flight (see that module).

Flight conditions are named in :data:`CONDITIONS`; ``ground`` has no air load.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from mapr_daemon.errors import ConfigError

FloatArray = npt.NDArray[np.float64]


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


def bit_profile(sample_rate_hz: float, cond: str = "ground", amplitude_deg: float = 20.0,
                ramp_s: float = 0.03, hold_s: float = 0.6, lead_s: float = 0.2) -> Profile:
    """The four-corner built-in-test position command (paper Fig. 16) at a steady condition.

    Timeline: ``lead_s`` at 0, ramp to ``amplitude_deg`` in ``ramp_s``, hold ``hold_s``, ramp
    back to 0 in ``ramp_s``, hold ``hold_s``. The default 20 deg in 30 ms asks for more speed
    than the motor has at 24 V, so the corners exercise the voltage and current limits.
    """
    if min(ramp_s, hold_s, lead_s) <= 0 or sample_rate_hz <= 0:
        raise ConfigError("timings and rate must be > 0", field="bit_profile")
    c = condition(cond)
    corners = (lead_s, lead_s + ramp_s, lead_s + ramp_s + hold_s,
               lead_s + 2 * ramp_s + hold_s)
    duration = corners[-1] + hold_s
    n = round(duration * sample_rate_hz)
    t = np.arange(1, n + 1) / sample_rate_hz
    cmd = np.interp(t, [0.0, *corners, duration], [0.0, 0.0, amplitude_deg, amplitude_deg,
                                                   0.0, 0.0])
    ones = np.ones(n)
    return Profile(
        name=f"bit@{c.name}", time_s=t, command_deg=cmd, altitude_m=ones * c.altitude_m,
        airspeed_mps=ones * c.airspeed_mps, density_kg_m3=ones * c.density_kg_m3,
        dynamic_pressure_pa=ones * c.dynamic_pressure_pa, corners_s=corners)


def steady_profile(sample_rate_hz: float, cond: str = "cruise", duration_s: float = 1.0,
                   command_deg: float = 0.0) -> Profile:
    """A steady flight with the surface held: the flight on which the testbed's flight control
    computer requests built-in tests (the EMA runs the BIT motion itself)."""
    if duration_s <= 0 or sample_rate_hz <= 0:
        raise ConfigError("duration and rate must be > 0", field="steady_profile")
    c = condition(cond)
    n = max(1, round(duration_s * sample_rate_hz))
    ones = np.ones(n)
    return Profile(
        name=f"steady@{c.name}", time_s=np.arange(1, n + 1) / sample_rate_hz,
        command_deg=ones * command_deg, altitude_m=ones * c.altitude_m,
        airspeed_mps=ones * c.airspeed_mps, density_kg_m3=ones * c.density_kg_m3,
        dynamic_pressure_pa=ones * c.dynamic_pressure_pa)


def sine_profile(sample_rate_hz: float, duration_s: float, amplitude_deg: float,
                 frequency_hz: float, cond: str = "cruise") -> Profile:
    """A sinusoidal command (used by tests and the observability bench for steady motion)."""
    c = condition(cond)
    n = round(duration_s * sample_rate_hz)
    t = np.arange(1, n + 1) / sample_rate_hz
    ones = np.ones(n)
    return Profile(
        name=f"sine{frequency_hz:g}Hz@{c.name}", time_s=t,
        command_deg=amplitude_deg * np.sin(2 * math.pi * frequency_hz * t),
        altitude_m=ones * c.altitude_m, airspeed_mps=ones * c.airspeed_mps,
        density_kg_m3=ones * c.density_kg_m3, dynamic_pressure_pa=ones * c.dynamic_pressure_pa)
