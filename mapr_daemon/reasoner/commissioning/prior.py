"""What commissioning may change in a data sheet, and by how much: the identification prior.

A data sheet (an actuator YAML) gives nominal values; a real unit differs from them by its
part-to-part tolerance (winding resistance +-10 %, capacitance -10/+20 %...). Commissioning
fits the parameters listed here, in log space (``theta = log(value / data sheet value)``),
with a Gaussian prior whose +-2 sd span the stated tolerance band: a tolerance of -10/+20 %
is a prior centred at ``log(sqrt(0.9 * 1.2))`` with sd ``(log 1.2 - log 0.9) / 4``.

The tolerance file (``configs/commissioning/tolerances.yaml``)::

    format: mapr-tolerances/1
    parameters:
      motor.resistance_ohm: 10          # +-10 %
      smps.capacitance_f: [-10, 20]     # -10 / +20 %

Any numeric ``section.key`` of the actuator file may be listed except ``sensors`` (the sensor
channels are the measurement, not the model); an unknown or non-numeric key is a
:class:`ConfigError` naming it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams, ChannelSpec
from mapr_daemon.errors import ConfigError

FORMAT = "mapr-tolerances/1"
PRIOR_SIGMAS = 2.0
"""The tolerance band is +- this many prior standard deviations (95 % of units inside)."""


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """One uncertain parameter: ``section.key`` of the actuator file, band in percent."""

    path: str
    minus_pct: float
    plus_pct: float

    @property
    def prior_mean(self) -> float:
        """Centre of the band in log space: the log of its geometric midpoint."""
        return 0.5 * (math.log1p(self.plus_pct / 100.0) + math.log1p(-self.minus_pct / 100.0))

    @property
    def prior_sd(self) -> float:
        span = math.log1p(self.plus_pct / 100.0) - math.log1p(-self.minus_pct / 100.0)
        return span / (2.0 * PRIOR_SIGMAS)


DEFAULT_TOLERANCES: tuple[Tolerance, ...] = (
    Tolerance("motor.resistance_ohm", 10.0, 10.0),
    Tolerance("motor.back_emf_v_s_per_rad", 5.0, 5.0),
    Tolerance("motor.inductance_h", 20.0, 20.0),
    Tolerance("motor.inertia_kg_m2", 15.0, 15.0),
    Tolerance("motor.viscous_friction_nm_s", 40.0, 40.0),
    Tolerance("motor.coulomb_friction_nm", 40.0, 40.0),
    Tolerance("gear.efficiency", 5.0, 5.0),
    Tolerance("smps.inductance_h", 20.0, 20.0),
    Tolerance("smps.capacitance_f", 10.0, 20.0),
    Tolerance("smps.esr_ohm", 30.0, 30.0),
)
"""Typical part-to-part tolerances of the blocks a BIT exercises (our choice, stated)."""

_NOT_IDENTIFIED = {"sensors", "name"}


def get(params: ActuatorParams, path: str) -> float:
    """The value of ``section.key``; :class:`ConfigError` if there is no such number."""
    section, _, key = path.partition(".")
    block = getattr(params, section, None) if section not in _NOT_IDENTIFIED else None
    value = getattr(block, key, None) if block is not None and key else None
    if not isinstance(value, float):
        raise ConfigError("not a numeric actuator parameter that can be identified",
                          field=path)
    return value


def scaled(params: ActuatorParams, factors: dict[str, float]) -> ActuatorParams:
    """A copy of ``params`` with each ``section.key`` multiplied by its factor."""
    by_section: dict[str, dict[str, float]] = {}
    for path, factor in factors.items():
        section, _, key = path.partition(".")
        by_section.setdefault(section, {})[key] = get(params, path) * factor
    out = params
    for section, values in by_section.items():
        out = dataclasses.replace(out, **{section: dataclasses.replace(
            getattr(out, section), **values)})
    return out


def quiet(params: ActuatorParams) -> ActuatorParams:
    """The reasoner's model of a recorded BIT: no sensor noise or quantisation, no bus drift
    or ripple, no drawn friction scatter (each BIT's friction is a parameter of the fit), so
    one set of parameters gives one smooth response and finite differences are exact to the
    step's truncation."""
    chans = {k: ChannelSpec(v.full_scale, 48.0, 0.0) for k, v in params.sensors.channels.items()}
    return dataclasses.replace(
        params, sensors=dataclasses.replace(params.sensors, channels=chans),
        motor=dataclasses.replace(params.motor, friction_flight_sd=0.0),
        bus=dataclasses.replace(params.bus, drift_sd_v=0.0, ripple_rms_v=0.0))


def prior(tolerances: Sequence[Tolerance]) -> tuple[FloatArray, FloatArray]:
    """Prior means and sds of ``theta`` (log of value over the data sheet value)."""
    return (np.array([t.prior_mean for t in tolerances]),
            np.array([t.prior_sd for t in tolerances]))


def _band(value: object, field: str, path: str) -> tuple[float, float]:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        minus, plus = float(value), float(value)
    elif (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        minus, plus = -float(value[0]), float(value[1])
    else:
        raise ConfigError("expected a percentage or [minus, plus] percentages", path=path,
                          field=field)
    if not (0.0 <= minus < 100.0 and plus >= 0.0 and minus + plus > 0.0
            and math.isfinite(plus)):
        raise ConfigError(f"band -{minus:g}/+{plus:g} % is not a tolerance", path=path,
                          field=field)
    return minus, plus


def parse_tolerances(text: str, path: str = "<string>",
                     params: ActuatorParams | None = None) -> tuple[Tolerance, ...]:
    """Read a tolerance file; with ``params``, every key must name one of its numbers."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(f"not valid YAML: {getattr(error, 'problem', error)}",
                          path=path) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ConfigError(f"expected format: {FORMAT}", path=path, field="format")
    items = doc.get("parameters")
    if not isinstance(items, dict) or not items:
        raise ConfigError("expected a mapping of section.key to a tolerance", path=path,
                          field="parameters")
    unknown = set(doc) - {"format", "parameters"}
    if unknown:
        raise ConfigError("unknown key", path=path, field=sorted(unknown)[0])
    out = []
    for key, value in items.items():
        field = f"parameters.{key}"
        minus, plus = _band(value, field, path)
        if params is not None:
            try:
                get(params, str(key))
            except ConfigError:
                raise ConfigError("not a numeric actuator parameter that can be identified",
                                  path=path, field=field) from None
        out.append(Tolerance(str(key), minus, plus))
    return tuple(out)


def load_tolerances(path: str | Path, params: ActuatorParams | None = None
                    ) -> tuple[Tolerance, ...]:
    """Read a tolerance file (see the module docstring)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=str(p)) from None
    return parse_tolerances(text, str(p), params)


def default_tolerances_path() -> Path:
    """The shipped tolerance file (the same bands as :data:`DEFAULT_TOLERANCES`)."""
    return (Path(__file__).resolve().parents[3] / "configs" / "commissioning"
            / "tolerances.yaml")
