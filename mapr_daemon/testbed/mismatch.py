"""Mismatched units: "aircraft" whose actuator differs from its data sheet, as real ones do.

The reasoner is built from an actuator file (the data sheet). A built unit differs from it
twice: every parameter by its part-to-part tolerance, and in model form — laws and loads no data
sheet lists (:class:`~mapr_daemon.ema.form.ModelForm`). :func:`draw_unit` draws one such unit
from a seed; :func:`fleet` draws many. A :class:`Unit` makes :class:`RunSpec` s, healthy or
faulted, at any flight condition, for the plant, ``mapr simulate --unit SEED`` or the reasoner's
``corpus.simulate_bit(..., specs=...)``. The simulator is a leaf: production code never imports
this module; it is handed the RunSpecs.

Part-to-part tolerances (relative to the data-sheet value; each drawn from a normal with sigma
half the tolerance, clipped at the tolerance, so about 5 % of units sit at a bound):

=================================== ========== ====================================================
parameter                           tolerance  source
=================================== ========== ====================================================
smps.output_voltage_v               +-1 %      reference IC initial accuracy (typical datasheets)
smps.inductance_h                   +-20 %     power-inductor tolerance "M" (+-20 %), datasheets
smps.inductor_resistance_ohm        +-10 %     our choice (DCR is specified typ/max)
smps.capacitance_f                  -10/+20 %  aluminium electrolytic, our choice inside "M"
smps.esr_ohm                        +-30 %     our choice (ESR is specified as a maximum)
smps.ceramic_capacitance_f          +-10 %     X7R tolerance "K" (+-10 %)
smps.ron_high_ohm, ron_low_ohm      +-20 %     MOSFET Rds(on): typical vs maximum ~1.2-1.3x
smps.loop_kp, loop_ki               +-10 %     compensator as built (our choice)
inverter.ron_a_high_ohm, ron_ohm    +-20 %     MOSFET Rds(on), as above
inverter.diode_drop_v               +-10 %     body-diode Vf spread (our choice)
motor.resistance_ohm                +-8 %      winding resistance, motor datasheets give +-5-12 %
motor.inductance_h                  +-20 %     winding inductance (our choice)
motor.back_emf_v_s_per_rad          +-5 %      torque/back-EMF constant, motor datasheets +-5-10 %
motor.inertia_kg_m2                 +-10 %     our choice
motor.viscous_friction_nm_s         +-40 %     friction and grease (our choice, +-30-50 %)
motor.coulomb_friction_nm           +-40 %     as above
gear.efficiency                     +-5 %      gear-train efficiency (our choice), capped at 0.99
surface.ch_delta_per_rad            +-15 %     hinge-moment slope estimated by handbook methods
surface.inertia_kg_m2               +-10 %     our choice
control.position_bandwidth_hz       +-10 %     loop gains as built (our choice)
control.position_damping            +-10 %     as above
control.position_integral_hz        +-10 %     as above
control.current_bandwidth_hz        +-10 %     as above
control.current_limit_a             +-5 %      current-sense resistor and comparator (our choice)
thermal.*_thermal_resistance_*      +-15 %     mounting and airflow (our choice)
bus.source_resistance_ohm           +-30 %     feeder wiring and connectors (our choice)
=================================== ========== ====================================================

The drive's gains follow from the drawn control block and the drawn plant (so "as built" means
the bandwidths are off by their tolerance). Model-form departures (:class:`FormSpread`, every
value our choice): stiction with probability 1/2 (breakaway 1.2-2.5x Coulomb, Stribeck speed
1-10 rad/s at the motor), a voltage-mode position loop with probability 1/4, discrete loop
rates with probability 1/2 (current loop 10 or 20 kHz, position loop 1 or 2 kHz), a
housekeeping load of 0.5-3 W varying by up to 30 % over 5-30 s, a Hall offset of up to +-6
electrical degrees, and on every ADC channel a gain error of up to +-1 % and an offset of up to
+-3 LSB (uniform).

Example::

    datasheet = load_actuator("configs/actuators/elevator-uav.yaml")
    units = fleet(datasheet, 20, seed=7)
    specs = [u.spec(seed=100 + k, ambient_c=-20.0, bus_v=26.0) for k, u in enumerate(units)]
    runs = simulate_bit(datasheet, [], [0.0] * 20, [], specs=specs)   # reasoner.corpus
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import CHANNELS, ActuatorParams


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """One parameter's part-to-part tolerance, relative: the unit's value lies in
    ``nominal * [1 - minus, 1 + plus]``."""

    path: str
    minus: float
    plus: float


def _sym(tol: float, *paths: str) -> list[Tolerance]:
    return [Tolerance(p, tol, tol) for p in paths]


TOLERANCES: tuple[Tolerance, ...] = tuple(
    _sym(0.01, "smps.output_voltage_v")
    + _sym(0.20, "smps.inductance_h")
    + _sym(0.10, "smps.inductor_resistance_ohm")
    + [Tolerance("smps.capacitance_f", 0.10, 0.20)]
    + _sym(0.30, "smps.esr_ohm")
    + _sym(0.10, "smps.ceramic_capacitance_f")
    + _sym(0.20, "smps.ron_high_ohm", "smps.ron_low_ohm")
    + _sym(0.10, "smps.loop_kp", "smps.loop_ki")
    + _sym(0.20, "inverter.ron_a_high_ohm", "inverter.ron_ohm")
    + _sym(0.10, "inverter.diode_drop_v")
    + _sym(0.08, "motor.resistance_ohm")
    + _sym(0.20, "motor.inductance_h")
    + _sym(0.05, "motor.back_emf_v_s_per_rad")
    + _sym(0.10, "motor.inertia_kg_m2")
    + _sym(0.40, "motor.viscous_friction_nm_s", "motor.coulomb_friction_nm")
    + _sym(0.05, "gear.efficiency")
    + _sym(0.15, "surface.ch_delta_per_rad")
    + _sym(0.10, "surface.inertia_kg_m2")
    + _sym(0.10, "control.position_bandwidth_hz", "control.position_damping",
           "control.position_integral_hz", "control.current_bandwidth_hz")
    + _sym(0.05, "control.current_limit_a")
    + _sym(0.15, "thermal.motor_thermal_resistance_k_per_w",
           "thermal.stage_thermal_resistance_k_per_w")
    + _sym(0.30, "bus.source_resistance_ohm"))
"""The module docstring's table, in draw order."""

MAX_EFFICIENCY = 0.99
"""A drawn gear efficiency is capped here (an efficiency above 1 is not a tolerance)."""


@dataclasses.dataclass(frozen=True)
class FormSpread:
    """The distribution model forms are drawn from (every value our choice, see the module)."""

    p_stiction: float = 0.5
    breakaway_ratio: tuple[float, float] = (1.2, 2.5)
    stribeck_speed_rad_s: tuple[float, float] = (1.0, 10.0)
    p_voltage_mode: float = 0.25
    p_discrete: float = 0.5
    current_loop_hz: tuple[float, ...] = (10e3, 20e3)
    position_loop_hz: tuple[float, ...] = (1e3, 2e3)
    housekeeping_w: tuple[float, float] = (0.5, 3.0)
    housekeeping_variation: tuple[float, float] = (0.0, 0.3)
    housekeeping_period_s: tuple[float, float] = (5.0, 30.0)
    hall_offset_deg: float = 6.0
    sensor_gain: float = 0.01
    sensor_offset_lsb: float = 3.0


@dataclasses.dataclass(frozen=True)
class Unit:
    """One built unit: its true parameters and model form, drawn from ``datasheet`` by ``seed``.

    ``factors`` maps each toleranced parameter (``section.key``) to its drawn value over the
    data sheet's.
    """

    seed: int
    datasheet: ActuatorParams
    params: ActuatorParams
    form: ModelForm
    factors: dict[str, float]

    def spec(self, faults: FaultSet | None = None, seed: int = 0,
             ambient_c: float | None = None, bus_v: float | None = None) -> RunSpec:
        """A run of this unit: its faults (none: healthy), noise seed and flight condition."""
        return RunSpec(self.params, faults or FaultSet(), seed=seed, ambient_c=ambient_c,
                       bus_v=bus_v, form=self.form)

    def describe(self) -> dict[str, Any]:
        """The unit's truth as a JSON-ready dict (``mapr simulate --unit`` writes it to meta)."""
        return {
            "seed": self.seed, "datasheet": self.datasheet.name,
            "factors": {k: round(v, 6) for k, v in self.factors.items()},
            "params": {k: _get(self.params, k) for k in self.factors},
            "form": self.form.describe(),
        }


def _get(params: ActuatorParams, path: str) -> float:
    section, key = path.split(".")
    return float(getattr(getattr(params, section), key))


def _set(params: ActuatorParams, path: str, value: float) -> ActuatorParams:
    section, key = path.split(".")
    block = dataclasses.replace(getattr(params, section), **{key: value})
    return dataclasses.replace(params, **{section: block})


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def draw_form(params: ActuatorParams, rng: np.random.Generator,
              spread: FormSpread = FormSpread()) -> ModelForm:
    """A model form from ``spread``; the sensor offsets are in ``params``'s channel LSBs.

    Every draw is made whether or not its option is taken, so one option's outcome does not
    shift the random numbers of the next.
    """
    stiction = rng.random() < spread.p_stiction
    breakaway = _uniform(rng, spread.breakaway_ratio)
    stribeck = _uniform(rng, spread.stribeck_speed_rad_s)
    voltage = rng.random() < spread.p_voltage_mode
    discrete = rng.random() < spread.p_discrete
    cur_hz = float(spread.current_loop_hz[int(rng.integers(len(spread.current_loop_hz)))])
    pos_hz = float(spread.position_loop_hz[int(rng.integers(len(spread.position_loop_hz)))])
    hk = _uniform(rng, spread.housekeeping_w)
    hk_var = _uniform(rng, spread.housekeeping_variation)
    hk_period = _uniform(rng, spread.housekeeping_period_s)
    hall = float(rng.uniform(-spread.hall_offset_deg, spread.hall_offset_deg))
    gains = rng.uniform(-spread.sensor_gain, spread.sensor_gain, len(CHANNELS))
    offsets = rng.uniform(-spread.sensor_offset_lsb, spread.sensor_offset_lsb, len(CHANNELS))
    lsb = [2.0 * params.sensors.channels[c].full_scale / 2.0 ** params.sensors.channels[c].bits
           for c in CHANNELS]
    return ModelForm(
        breakaway_ratio=breakaway if stiction else 0.0, stribeck_speed_rad_s=stribeck,
        voltage_mode=bool(voltage), current_loop_hz=cur_hz if discrete else 0.0,
        position_loop_hz=pos_hz if discrete else 0.0, housekeeping_w=hk,
        housekeeping_variation=hk_var, housekeeping_period_s=hk_period, hall_offset_deg=hall,
        sensor_gain=tuple((c, 1.0 + float(g)) for c, g in zip(CHANNELS, gains, strict=True)),
        sensor_offset=tuple((c, float(o) * w) for c, o, w in zip(CHANNELS, offsets, lsb,
                                                                  strict=True)))


def draw_unit(datasheet: ActuatorParams, seed: int,
              spread: FormSpread = FormSpread()) -> Unit:
    """One unit off ``datasheet``: parameters within :data:`TOLERANCES`, a form from
    ``spread``. The same data sheet and seed give the same unit."""
    rng = np.random.default_rng(seed)
    params = datasheet
    factors: dict[str, float] = {}
    for tol in TOLERANCES:
        z = float(np.clip(rng.standard_normal() * 0.5, -1.0, 1.0))
        factor = 1.0 + z * (tol.plus if z > 0.0 else tol.minus)
        value = _get(datasheet, tol.path) * factor
        if tol.path == "gear.efficiency":
            value = min(value, MAX_EFFICIENCY)
        factors[tol.path] = value / _get(datasheet, tol.path)
        params = _set(params, tol.path, value)
    params = dataclasses.replace(params, name=f"{datasheet.name}#unit{seed}")
    return Unit(seed, datasheet, params, draw_form(datasheet, rng, spread), factors)


def twin(datasheet: ActuatorParams, seed: int) -> Unit:
    """A unit that is the data sheet's exact twin: every factor 1, the plant's own form (what
    a bench run on mismatched units allows when the model is exact)."""
    params = dataclasses.replace(datasheet, name=f"{datasheet.name}#twin{seed}")
    return Unit(seed, datasheet, params, ModelForm(), {})


def fleet(datasheet: ActuatorParams, n: int, seed: int,
          spread: FormSpread = FormSpread()) -> list[Unit]:
    """``n`` units off one data sheet; unit ``k``'s seed is derived from ``seed`` and ``k``
    (``unit.seed`` redraws it alone with :func:`draw_unit`)."""
    seeds = np.random.SeedSequence(seed).generate_state(n, dtype=np.uint32)
    return [draw_unit(datasheet, int(s), spread) for s in seeds]
