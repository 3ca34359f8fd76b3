"""The built-in-test profile, built from the actuator's ``bit:`` section.

The EMA's drive stores its BIT motion and runs it itself when the flight control computer
requests it; the motion is a property of the actuator (:class:`~mapr_daemon.ema.params.BitParams`,
the ``bit:`` section of its YAML), not of any simulator. Three users share this one builder,
so they cannot drift apart: the reasoner flies the plant model over it to build its fault
dictionary, the daemon aligns a BIT it finds on the bus on its time axis, and the simulated
EMA (:mod:`mapr_daemon.testbed`) runs it on the loopback bus.

The profile's first sample is the drive's first sample after the request (one sample period
after time 0); its corners are the four instants where the command's slope changes.
"""

from __future__ import annotations

import functools

import numpy as np

from mapr_daemon.ema.params import BitParams, default_actuator_path, load_actuator
from mapr_daemon.ema.profile import Profile, condition, steady
from mapr_daemon.errors import ConfigError


@functools.cache
def default_bit() -> BitParams:
    """The shipped default actuator's ``bit:`` section (read once per process)."""
    return load_actuator(default_actuator_path()).bit


def corners_s(bit: BitParams) -> tuple[float, float, float, float]:
    """Start and end of the ramp up, start and end of the ramp down (s from the request)."""
    up = bit.lead_s + bit.ramp_s
    down = up + bit.hold_s
    return bit.lead_s, up, down, down + bit.ramp_s


def bit_profile(sample_rate_hz: float, cond: str = "ground",
                bit: BitParams | None = None) -> Profile:
    """The four-corner BIT command of ``bit`` (default: :func:`default_bit`) sampled at
    ``sample_rate_hz``, flown at the named steady condition (``ground``: no air load)."""
    spec = default_bit() if bit is None else bit
    if min(spec.ramp_s, spec.hold_s, spec.lead_s) <= 0 or sample_rate_hz <= 0:
        raise ConfigError("timings and rate must be > 0", field="bit")
    c = condition(cond)
    corners = corners_s(spec)
    duration = corners[-1] + spec.hold_s
    n = round(duration * sample_rate_hz)
    t = np.arange(1, n + 1) / sample_rate_hz
    cmd = np.interp(t, [0.0, *corners, duration],
                    [0.0, 0.0, spec.amplitude_deg, spec.amplitude_deg, 0.0, 0.0])
    return steady(f"bit@{c.name}", t, cmd, c, corners)
