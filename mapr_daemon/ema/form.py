"""Model-form options of the plant: how a real actuator departs from what its data sheet says.

An actuator file (:mod:`mapr_daemon.ema.params`) holds values a data sheet carries: resistances,
inertias, gains. A built unit also differs in *form* — laws and loads no data sheet lists — and
a reasoner built from the file's model must be tested against such units, not only against its
own twin. :class:`ModelForm` is one run's choice of form; ``ModelForm()`` is the model as it
always was (smoothed Coulomb friction, a current-mode drive computed every step, no housekeeping
load, Hall sensors exactly aligned, ideal ADC gains), and with it the plant's output is
bit-identical to a run without any form.

Options (each independent; ``mapr_daemon.ema.step`` computes them, ``plant.py`` applies the
sensor errors):

* **friction** — ``breakaway_ratio`` > 0 switches the motor-shaft friction from
  ``Tc tanh(w/ws) + B w`` to true stiction: at rest the shaft stays stuck until the applied
  torque exceeds the breakaway torque ``breakaway_ratio * Tc`` (>= Tc), then slides with the
  Stribeck law ``sgn(w) (Tc + (Ts - Tc) exp(-(w/stribeck_speed)^2)) + B w``; a speed that
  crosses zero sticks again (Karnopp). The Coulomb level follows the friction fault and the
  flight scatter, so the breakaway torque does too.
* **control law** — ``voltage_mode`` replaces the cascaded loops (position PID -> current
  command -> current PI) by a position PID whose output is a voltage, with back-EMF
  feed-forward (``V = R_loop (kp e + I - kd w) + 2K w``, the drive's nominal loop
  resistance ``2 (R + Ron)``), the phase current only limited: the voltage is clamped to
  ``2K w +- R_loop i_lim``. ``current_loop_hz`` / ``position_loop_hz`` > 0 compute the loops
  at a discrete controller rate (zero-order hold in between) instead of every integrator step;
  the rate is rounded to a whole number of steps.
* **housekeeping load** — ``housekeeping_w`` of constant power drawn from the 24 V DC link
  upstream of the DC-link current sensor (gate drives, logic, a fan), varying by
  ``+- housekeeping_variation`` (relative) with period ``housekeeping_period_s``.
* **commutation offset** — ``hall_offset_deg`` (electrical degrees): the Hall sensors are
  mounted off, so the drive commutates a sector early or late while the back-EMF follows the
  true rotor angle (less torque per ampere).
* **sensor errors** — ``sensor_gain`` / ``sensor_offset``: ``(channel, value)`` pairs for ADC
  channels (:data:`~mapr_daemon.ema.params.CHANNELS`); the channel reads
  ``gain * true + offset`` (offset in the channel's unit) before noise and quantisation.

Example::

    form = ModelForm(breakaway_ratio=1.6, hall_offset_deg=4.0, housekeeping_w=2.0,
                     sensor_gain=(("dc_link_current_a", 1.01),))
    plant = EmaBatch([RunSpec(params, form=form, seed=1)])
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from mapr_daemon.ema.params import CHANNELS
from mapr_daemon.errors import ConfigError

MAX_HALL_OFFSET_DEG = 30.0
"""Half a Hall sector: beyond it the drive would commutate into the wrong sector."""


@dataclasses.dataclass(frozen=True)
class ModelForm:
    """One unit's model form; the defaults are the plant as the actuator file describes it."""

    breakaway_ratio: float = 0.0
    """0: smoothed Coulomb + viscous friction; >= 1: stiction, breakaway torque over Coulomb."""
    stribeck_speed_rad_s: float = 2.0
    """Motor-shaft speed over which the friction decays from breakaway to Coulomb."""
    voltage_mode: bool = False
    """Position loop straight to voltage, current only limited (no current loop)."""
    current_loop_hz: float = 0.0
    """Discrete current-loop rate (0: every integrator step)."""
    position_loop_hz: float = 0.0
    """Discrete position-loop rate (0: every integrator step)."""
    housekeeping_w: float = 0.0
    """Constant-power load on the DC link, W."""
    housekeeping_variation: float = 0.0
    """Relative amplitude of its slow sinusoidal variation (0..1)."""
    housekeeping_period_s: float = 10.0
    """Period of that variation, s."""
    hall_offset_deg: float = 0.0
    """Hall sensor mounting error, electrical degrees (+ commutates early)."""
    sensor_gain: tuple[tuple[str, float], ...] = ()
    """(channel, gain) pairs; channels not named read with gain 1."""
    sensor_offset: tuple[tuple[str, float], ...] = ()
    """(channel, offset in the channel's unit) pairs; channels not named read with 0."""

    def __post_init__(self) -> None:
        checks = (
            ("breakaway_ratio", self.breakaway_ratio == 0.0 or self.breakaway_ratio >= 1.0,
             "0 (off) or >= 1"),
            ("stribeck_speed_rad_s", self.stribeck_speed_rad_s > 0.0, "> 0"),
            ("current_loop_hz", self.current_loop_hz >= 0.0, ">= 0"),
            ("position_loop_hz", self.position_loop_hz >= 0.0, ">= 0"),
            ("housekeeping_w", self.housekeeping_w >= 0.0, ">= 0"),
            ("housekeeping_variation", 0.0 <= self.housekeeping_variation <= 1.0, "in [0, 1]"),
            ("housekeeping_period_s", self.housekeeping_period_s > 0.0, "> 0"),
            ("hall_offset_deg", abs(self.hall_offset_deg) < MAX_HALL_OFFSET_DEG,
             f"within +-{MAX_HALL_OFFSET_DEG:g}"),
        )
        for name, ok, want in checks:
            value = getattr(self, name)
            if not (math.isfinite(float(value)) and ok):
                raise ConfigError(f"must be {want}, got {value!r}", field=f"form.{name}")
        for field, pairs in (("sensor_gain", self.sensor_gain),
                             ("sensor_offset", self.sensor_offset)):
            for channel, value in pairs:
                if channel not in CHANNELS:
                    raise ConfigError(f"unknown channel {channel!r}", field=f"form.{field}")
                if not math.isfinite(value) or (field == "sensor_gain" and value <= 0.0):
                    raise ConfigError(f"bad value {value!r} for {channel}",
                                      field=f"form.{field}")

    @property
    def is_default(self) -> bool:
        return self == ModelForm()

    def gains(self) -> list[float]:
        """Per-channel gains in :data:`CHANNELS` order."""
        named = dict(self.sensor_gain)
        return [float(named.get(c, 1.0)) for c in CHANNELS]

    def offsets(self) -> list[float]:
        """Per-channel offsets in :data:`CHANNELS` order."""
        named = dict(self.sensor_offset)
        return [float(named.get(c, 0.0)) for c in CHANNELS]

    def loop_steps(self, step_s: float) -> tuple[int, int]:
        """Integrator steps per current-loop and per position-loop update (1: every step)."""
        def steps(hz: float, name: str) -> int:
            if hz == 0.0:
                return 1
            n = round(1.0 / (hz * step_s))
            if n < 1:
                raise ConfigError(f"{hz:g} Hz is faster than the integrator step",
                                  field=f"form.{name}")
            return int(n)
        return steps(self.current_loop_hz, "current_loop_hz"), steps(self.position_loop_hz,
                                                                       "position_loop_hz")

    def describe(self) -> dict[str, Any]:
        """A JSON-ready dict of the form (for run metadata); :meth:`from_description` reads it."""
        out = dataclasses.asdict(self)
        out["sensor_gain"] = dict(self.sensor_gain)
        out["sensor_offset"] = dict(self.sensor_offset)
        return out

    @classmethod
    def from_description(cls, d: dict[str, Any]) -> ModelForm:
        """The form :meth:`describe` wrote (e.g. a ``mapr simulate --unit`` file's
        ``meta_json["unit"]["form"]``); an unknown or bad field is a :class:`ConfigError`."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ConfigError(f"unknown field(s) {', '.join(unknown)}", field="form")
        values = dict(d)
        for name in ("sensor_gain", "sensor_offset"):
            if name in values:
                values[name] = tuple((str(c), float(v)) for c, v in dict(values[name]).items())
        try:
            return cls(**values)
        except TypeError as error:
            raise ConfigError(str(error), field="form") from None
