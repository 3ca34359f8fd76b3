"""Flights that drive the simulated EMA: steady, sinusoidal and built-in-test profiles.

The :class:`~mapr_daemon.ema.profile.Profile` type, the named flight conditions and the
BIT profile itself are production code (:mod:`mapr_daemon.ema.profile`,
:mod:`mapr_daemon.ema.bit`: the BIT motion is the actuator's ``bit:`` section); they are
re-exported here for the simulator's users. What is the simulator's own:

* :func:`bit_profile` — the actuator's BIT motion with any timing overridden (tests and
  benches fly shortened BITs).
* :func:`steady_profile` — a steady flight with the surface held, on which the testbed's
  flight control computer requests built-in tests.
* :func:`sine_profile` — a sinusoidal command.
* :func:`mapr_daemon.testbed.profiles_jsbsim.jsbsim_flight` — a JSBSim flight.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from mapr_daemon.ema import bit as ema_bit
from mapr_daemon.ema.params import BitParams
from mapr_daemon.ema.profile import CONDITIONS, Condition, Profile, condition, isa_density
from mapr_daemon.errors import ConfigError

__all__ = ["CONDITIONS", "Condition", "Profile", "bit_profile", "condition", "isa_density",
           "sine_profile", "steady_profile"]


def bit_profile(sample_rate_hz: float, cond: str = "ground", amplitude_deg: float | None = None,
                ramp_s: float | None = None, hold_s: float | None = None,
                lead_s: float | None = None, *, bit: BitParams | None = None) -> Profile:
    """The actuator's BIT profile (``bit``, default the shipped actuator's) at a steady
    condition, with any of its timings overridden."""
    spec = ema_bit.default_bit() if bit is None else bit
    given = {"amplitude_deg": amplitude_deg, "ramp_s": ramp_s, "hold_s": hold_s,
             "lead_s": lead_s}
    spec = dataclasses.replace(spec, **{k: float(v) for k, v in given.items() if v is not None})
    return ema_bit.bit_profile(sample_rate_hz, cond, spec)

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
