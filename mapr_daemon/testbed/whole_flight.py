"""Whole flights for the in-flight tracker: taxi, climb, cruise, approach, as surface activity.

:func:`flight_profile` strings the phases of a flight into one
:class:`~mapr_daemon.ema.profile.Profile` at the plant's sample rate:

* **taxi out** (on the ground, no air load): the pre-flight control check (three full-travel
  sweeps, 2 s each), then the surface held with a few small taps;
* **climb**, **cruise turns** and **approach**: JSBSim's c172x flying its bank-angle schedule
  at the named condition (:func:`~mapr_daemon.testbed.profiles_jsbsim.jsbsim_flight`; the
  schedule's seed varies per flight);
* **cruise hold**: the surface near trim with slow small corrections (filtered noise of
  0.3 deg rms), the long quiet stretch of a real flight;
* **taxi in**: held on the ground.

Scaling: a real flight is hours; this one is a few minutes with the phases in roughly a
real flight's proportions of *activity* (a short control check, manoeuvring climb and
approach, a long quiet cruise). ``scale`` multiplies every phase's length (tests fly 0.2).
The tracker's per-flight noise falls with the excited time it sees, so an hours-long flight
with the same mix would give a smaller sd; the figures are for the flight as flown here.

:func:`fly` flies the plant directly at the bus rate (no bus, no ICD: the tracker reads the
same channels the pipeline would hand it) and returns each run's channels with the truth the
bench scores against: that flight's friction factor (fault x the flight's grease scatter)
and the parts' values at the flight's ambient temperature.

Example::

    prof = flight_profile(2000.0, seed=3)
    flown = fly([unit.spec(FaultSet.of([Fault("friction", 2.0)]), seed=9)], prof)
    flown.channels[0]["phase_a_current_a"], flown.truth[0].friction_factor
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from scipy.signal import lfilter

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec, build
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.ema.profile import Profile, condition
from mapr_daemon.errors import ConfigError
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

PHASES_S: tuple[tuple[str, float], ...] = (
    ("taxi_out", 30.0), ("climb", 45.0), ("cruise_turns", 30.0), ("cruise_hold", 90.0),
    ("approach", 45.0), ("taxi_in", 15.0))
"""Phase names and lengths (s) at ``scale=1``: 255 s of bus per flight."""


def _ground(rate: float, duration_s: float, command: FloatArray) -> Profile:
    n = command.size
    c = condition("ground")
    ones = np.ones(n)
    return Profile(name="ground", time_s=np.arange(1, n + 1) / rate, command_deg=command,
                   altitude_m=ones * c.altitude_m, airspeed_mps=ones * c.airspeed_mps,
                   density_kg_m3=ones * c.density_kg_m3,
                   dynamic_pressure_pa=ones * c.dynamic_pressure_pa)


def _taxi_out(rate: float, duration_s: float, rng: np.random.Generator,
              travel_deg: float) -> FloatArray:
    n = round(duration_s * rate)
    t = np.arange(n) / rate
    cmd = np.zeros(n)
    sweep = 2.0
    check = (t >= 2.0) & (t < 2.0 + 3 * sweep)
    cmd[check] = 0.8 * travel_deg * np.sin(2 * math.pi * (t[check] - 2.0) / sweep)
    for tap in rng.uniform(2.0 + 3 * sweep, max(duration_s, 2.0 + 3 * sweep + 1e-3), 3):
        cmd += rng.uniform(-4.0, 4.0) * ((t >= tap) & (t < tap + 0.5))
    return cmd


def _hold(rate: float, duration_s: float, rng: np.random.Generator, cond: str) -> Profile:
    """Cruise near trim: filtered noise (0.5 s time constant) scaled to 0.3 deg rms."""
    n = round(duration_s * rate)
    c = condition(cond)
    a = math.exp(-1.0 / (0.5 * rate))
    x: FloatArray = lfilter([1.0], [1.0, -a], rng.standard_normal(n))
    x *= 0.3 / max(float(np.std(x)), 1e-12)
    ones = np.ones(n)
    return Profile(name=f"hold@{cond}", time_s=np.arange(1, n + 1) / rate,
                   command_deg=x + rng.uniform(-1.0, 1.0), altitude_m=ones * c.altitude_m,
                   airspeed_mps=ones * c.airspeed_mps, density_kg_m3=ones * c.density_kg_m3,
                   dynamic_pressure_pa=ones * c.dynamic_pressure_pa)


def _join(parts: Sequence[Profile], rate: float, name: str) -> Profile:
    def cat(field: str) -> FloatArray:
        return np.concatenate([getattr(p, field) for p in parts])

    n = sum(p.n_samples for p in parts)
    return Profile(name=name, time_s=np.arange(1, n + 1) / rate, command_deg=cat("command_deg"),
                   altitude_m=cat("altitude_m"), airspeed_mps=cat("airspeed_mps"),
                   density_kg_m3=cat("density_kg_m3"),
                   dynamic_pressure_pa=cat("dynamic_pressure_pa"))


def flight_profile(sample_rate_hz: float, seed: int, scale: float = 1.0,
                   travel_deg: float = 25.0, surface: str = "aileron") -> Profile:
    """One whole flight (the phases of :data:`PHASES_S`, each ``scale`` times as long)."""
    if scale <= 0.0:
        raise ConfigError("scale must be > 0", field="scale")
    rng = np.random.default_rng(seed)
    rate = float(sample_rate_hz)
    dur = {k: v * scale for k, v in PHASES_S}
    parts = [
        _ground(rate, dur["taxi_out"], _taxi_out(rate, dur["taxi_out"], rng, travel_deg)),
        jsbsim_flight(rate, "climb", dur["climb"], surface, seed=seed * 4 + 1),
        jsbsim_flight(rate, "cruise", dur["cruise_turns"], surface, seed=seed * 4 + 2),
        _hold(rate, dur["cruise_hold"], rng, "cruise"),
        jsbsim_flight(rate, "approach", dur["approach"], surface, seed=seed * 4 + 3),
        _ground(rate, dur["taxi_in"], np.zeros(round(dur["taxi_in"] * rate))),
    ]
    return _join(parts, rate, f"flight{seed}x{scale:g}")


@dataclasses.dataclass(frozen=True)
class FlightTruth:
    """One run's true parameters over a flight (what the tracker should read)."""

    friction_factor: float
    """The flight's friction over the unit's own healthy nominal (fault x grease scatter)."""
    ron_a_high_ohm: float
    """Phase-A high-side Ron at the flight's ambient."""
    ron_ohm: float
    """The other switches' Ron at the flight's ambient."""
    esr_ohm: float
    capacitance_f: float
    ambient_c: float
    winding_ohm: float
    """One winding's resistance, the flight's mean (it follows the motor's temperature)."""

    @property
    def loop_ohm(self) -> float:
        """Two windings and two switches: the loop resistance outside phase A's sectors."""
        return 2.0 * (self.winding_ohm + self.ron_ohm)


@dataclasses.dataclass(frozen=True)
class Flown:
    """The runs of one flight: per run, the 1-D channels and the truth."""

    profile: Profile
    channels: list[dict[str, FloatArray]]
    truth: list[FlightTruth]


def fly(specs: Sequence[RunSpec], profile: Profile, chunk: int = 4000) -> Flown:
    """Fly every run over ``profile`` (the plant directly, at the bus rate)."""
    plant = EmaBatch(specs)
    healthy = build([dataclasses.replace(s, faults=type(s.faults)()) for s in specs])
    p = plant.p
    n = profile.n_samples
    parts = []
    winding = np.zeros(p.n)
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        block = plant.advance(stop - start, profile.command_deg[None, start:stop],
                              profile.dynamic_pressure_pa[None, start:stop])
        parts.append(block.channels)
        winding += block.truth["winding_resistance_ohm"].sum(axis=1)
    names = list(parts[0])
    joined = {k: np.concatenate([b[k] for b in parts], axis=1) for k in names}
    channels = [{k: np.ascontiguousarray(joined[k][r]) for k in names} for r in range(p.n)]
    truth = [FlightTruth(
        friction_factor=float(p.t_coul[r] / healthy.t_coul[r]),
        ron_a_high_ohm=float(p.r_high[0, r]), ron_ohm=float(p.r_high[1, r]),
        esr_ohm=float(p.esr[r]), capacitance_f=float(p.c_elec[r]),
        ambient_c=float(p.t_amb[r]), winding_ohm=float(winding[r] / n)) for r in range(p.n)]
    return Flown(profile, channels, truth)
