"""Actuator parameters: one frozen dataclass per physical block, loaded from one YAML per actuator.

The YAML (``configs/actuators/*.yaml``) has one mapping per block — ``smps``, ``inverter``,
``motor``, ``gear``, ``surface``, ``control``, ``thermal``, ``bus``, ``envelope``, ``sensors``,
``bit`` (the drive's stored built-in-test motion) — whose keys are
the field names below, SI units spelled in the name (``_ohm``, ``_h``, ``_f``, ``_hz``...).
Every key is required and no unknown key is allowed, so a typo is a :class:`ConfigError`
naming ``file:line: section.key``, never a silently ignored value. One section is optional:
``switches`` (the per-switch thermal nodes behind the switch temperature channels,
:class:`SwitchThermalParams`); a file without it gets :data:`DEFAULT_SWITCHES`, and when
present every key of it is required like any other section's.

Example::

    params = load_actuator("configs/actuators/aileron-uav.yaml")
    params.smps.capacitance_f      # 288e-6
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, TypeVar

import yaml

from mapr_daemon.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class SmpsParams:
    """Synchronous buck from the aircraft bus to the 24 V DC link (paper Fig. 3, Table 1)."""

    output_voltage_v: float
    inductance_h: float
    inductor_resistance_ohm: float
    capacitance_f: float
    esr_ohm: float
    ceramic_capacitance_f: float
    ron_high_ohm: float
    ron_low_ohm: float
    switching_frequency_hz: float
    max_duty: float
    current_limit_a: float
    soft_start_s: float
    loop_kp: float
    loop_ki: float
    loop_kd: float
    loop_derivative_filter_s: float
    switching_loss_w: float


@dataclasses.dataclass(frozen=True)
class InverterParams:
    """Three-phase MOSFET bridge with body diodes, six-step commutation from Hall sectors."""

    ron_a_high_ohm: float
    ron_ohm: float
    diode_drop_v: float
    diode_resistance_ohm: float
    short_resistance_ohm: float
    pwm_frequency_hz: float
    pwm_counter_period: float
    """Timer counts per PWM period: the controller sets (and reports) its duty in whole counts."""


@dataclasses.dataclass(frozen=True)
class MotorParams:
    """BLDC motor, per-phase values, trapezoidal back-EMF (120 degree flat tops)."""

    resistance_ohm: float
    inductance_h: float
    back_emf_v_s_per_rad: float
    pole_pairs: float
    inertia_kg_m2: float
    viscous_friction_nm_s: float
    coulomb_friction_nm: float
    coulomb_speed_rad_s: float
    friction_flight_sd: float
    breakaway_ratio: float = 0.0
    """The friction law: 0 the smoothed Coulomb plus viscous law; >= 1 stiction, the shaft
    held at rest up to this many times the Coulomb torque, the friction decaying to Coulomb
    with the Stribeck speed (the plant's law of :class:`~mapr_daemon.ema.form.ModelForm`). A
    data sheet leaves it out; commissioning chooses it from the unit's BITs
    (:mod:`~mapr_daemon.reasoner.commissioning.friction_law`)."""
    stribeck_speed_rad_s: float = 2.0
    """Motor-shaft speed over which stiction decays to Coulomb (with a breakaway ratio)."""


@dataclasses.dataclass(frozen=True)
class GearParams:
    """Gear train between motor and surface hinge (rigid)."""

    ratio: float
    efficiency: float


@dataclasses.dataclass(frozen=True)
class SurfaceParams:
    """Control surface: hinge moment H = q * area * chord * (ch0 + ch_delta * delta)."""

    area_m2: float
    chord_m: float
    ch0: float
    ch_delta_per_rad: float
    inertia_kg_m2: float
    travel_deg: float


@dataclasses.dataclass(frozen=True)
class ControlParams:
    """Servo drive: position loop (PID) -> current command with limit -> current PI -> duty."""

    position_bandwidth_hz: float
    position_damping: float
    position_integral_hz: float
    current_limit_a: float
    current_bandwidth_hz: float


@dataclasses.dataclass(frozen=True)
class ThermalParams:
    """First-order thermal models of the motor winding and the power stage."""

    ambient_c: float
    ambient_flight_sd_k: float
    motor_thermal_resistance_k_per_w: float
    motor_time_constant_s: float
    stage_thermal_resistance_k_per_w: float
    stage_time_constant_s: float


@dataclasses.dataclass(frozen=True)
class SwitchThermalParams:
    """First-order thermal nodes of single power switches, each above the shared heat sink.

    The SMPS's high and low side and the inverter's phase-A high side each heat their own
    junction by their own loss (conduction, plus the SMPS's switching loss on its high side);
    the junction's rise over the sink (the power stage's temperature) settles at
    ``resistance * loss`` with the time constant. A temperature-sensing MOSFET (an on-die diode)
    reads it ``sensor_rate_hz`` times a second through an integrating ADC (each reading the
    mean over its period, held until the next); docs/ema-model.md gives the values' sources.
    """

    smps_thermal_resistance_k_per_w: float
    smps_time_constant_s: float
    inverter_thermal_resistance_k_per_w: float
    inverter_time_constant_s: float
    sensor_rate_hz: float


DEFAULT_SWITCHES = SwitchThermalParams(
    smps_thermal_resistance_k_per_w=3.6, smps_time_constant_s=0.5,
    inverter_thermal_resistance_k_per_w=1.65, inverter_time_constant_s=0.5,
    sensor_rate_hz=100.0)
"""An actuator file without a ``switches`` section: IRF520N-class SMPS switches (TO-220
datasheet: Rth(j-c) 3.1 K/W, case to sink 0.5 K/W greased) and an IRF540N-class inverter
switch (Rth(j-c) 1.15 K/W plus 0.5 K/W); time constants our reading of such parts' transient
thermal impedance (settled within about a second); read at 100 Hz, the rate the ICD's
slow block carries temperatures at. docs/ema-model.md, "Switch temperatures"."""


@dataclasses.dataclass(frozen=True)
class BusParams:
    """Aircraft 28 V DC bus feeding the SMPS (MIL-STD-704 normal band 22-29 V)."""

    nominal_v: float
    flight_mean_sd_v: float
    drift_sd_v: float
    drift_time_constant_s: float
    ripple_rms_v: float
    min_v: float
    max_v: float
    source_resistance_ohm: float


@dataclasses.dataclass(frozen=True)
class EnvelopeParams:
    """The operating envelope the actuator is specified for, and the reasoner must cover.

    Dynamic pressure from 0 (a BIT on the ground) to ``max_dynamic_pressure_pa``; ambient
    temperature from ``ambient_min_c`` to ``ambient_max_c`` (DO-160 operating categories: -40
    to +70 C is a common one); the aircraft bus voltage over ``bus.min_v``..``bus.max_v``.
    """

    max_dynamic_pressure_pa: float
    ambient_min_c: float
    ambient_max_c: float


@dataclasses.dataclass(frozen=True)
class BitParams:
    """The built-in-test motion the drive stores and runs on request (paper Fig. 16).

    A property of the actuator, like its gear ratio: the drive's firmware holds it, the
    reasoner's dictionary is flown over it and the daemon aligns a BIT found on the bus on
    it (:mod:`mapr_daemon.ema.bit` builds the command). Timeline: ``lead_s`` at 0, ramp to
    ``amplitude_deg`` in ``ramp_s``, hold ``hold_s``, ramp back to 0 in ``ramp_s``, hold
    ``hold_s``: four corners at which the drive runs into its voltage and current limits.
    """

    amplitude_deg: float
    ramp_s: float
    hold_s: float
    lead_s: float


@dataclasses.dataclass(frozen=True)
class ChannelSpec:
    """One ADC channel: signed full scale, resolution bits and white-noise RMS (in units)."""

    full_scale: float
    bits: float
    noise_rms: float


@dataclasses.dataclass(frozen=True)
class SensorParams:
    """Sensor channels as the testbed samples them (all averaged over the sample period)."""

    sample_rate_hz: float
    step_s: float
    channels: dict[str, ChannelSpec]


@dataclasses.dataclass(frozen=True)
class ActuatorParams:
    """Every parameter of one EMA; the faults module derives seeded copies from it."""

    name: str
    smps: SmpsParams
    inverter: InverterParams
    motor: MotorParams
    gear: GearParams
    surface: SurfaceParams
    control: ControlParams
    thermal: ThermalParams
    bus: BusParams
    envelope: EnvelopeParams
    sensors: SensorParams
    bit: BitParams
    switches: SwitchThermalParams = DEFAULT_SWITCHES
    """Optional in the file (:data:`DEFAULT_SWITCHES` when absent)."""


CHANNELS: tuple[str, ...] = (
    "dc_link_current_a", "phase_a_current_a", "phase_b_current_a", "phase_c_current_a",
    "dc_bus_voltage_v", "position_deg", "motor_temperature_c", "smps_input_voltage_v",
    "smps_input_current_a", "stage_temperature_c", "ripple_rms_v",
)
"""Sensor channels every actuator file must specify, in output order."""

CONTROLLER_CHANNELS: tuple[str, ...] = ("commutation_sector", "inverter_duty")
"""What the servo drive reports of its own state, after the sensor channels: no ADC, no noise.

``commutation_sector`` is the Hall sector (1-6) the inverter commutates in at the sample
instant (phase A's high side is the PWM'd switch in sectors 1 and 2 for positive torque, in
4 and 5 for negative); ``inverter_duty`` is the applied PWM duty averaged over the sample
period, signed with the drive direction (+ = positive torque), as the controller knows it:
exact, in whole counts of its PWM timer (``inverter.pwm_counter_period``) averaged over the
PWM periods of a sample."""
SWITCH_CHANNELS: tuple[str, ...] = (
    "smps_high_side_temperature_c", "smps_low_side_temperature_c",
    "inverter_a_high_temperature_c")
"""Per-switch junction temperatures (:class:`SwitchThermalParams`), after the controller's
channels: sensors an actuator may or may not have (the ICD carries them or not). Sampled
like ``stage_temperature_c`` (its full scale, bits and noise), with noise of their own
stream, so every channel before them is the same with or without them."""
OUTPUT_CHANNELS: tuple[str, ...] = CHANNELS + CONTROLLER_CHANNELS + SWITCH_CHANNELS
"""Every channel a plant block carries, in order."""

_T = TypeVar("_T")
_SECTIONS: dict[str, type[Any]] = {
    "smps": SmpsParams, "inverter": InverterParams, "motor": MotorParams, "gear": GearParams,
    "surface": SurfaceParams, "control": ControlParams, "thermal": ThermalParams,
    "bus": BusParams, "envelope": EnvelopeParams, "bit": BitParams,
}
SECTION_NAMES: tuple[str, ...] = tuple(_SECTIONS)
"""The actuator file's numeric sections besides ``sensors``, in the order files write them."""
OPTIONAL_SECTIONS: dict[str, type[Any]] = {"switches": SwitchThermalParams}
"""Sections a file may leave out (the dataclass field's default then holds)."""
_MAY_BE_ZERO_OR_NEGATIVE = {
    "ch0", "ch_delta_per_rad", "ambient_c", "loop_kd", "soft_start_s", "noise_rms",
    "drift_sd_v", "flight_mean_sd_v", "ripple_rms_v", "source_resistance_ohm",
    "switching_loss_w", "position_integral_hz", "friction_flight_sd", "ambient_flight_sd_k",
    "ambient_min_c", "ambient_max_c", "breakaway_ratio",
}


def _line(node: yaml.Node) -> int:
    return int(node.start_mark.line) + 1


def _mapping(node: yaml.Node, path: str, field: str) -> dict[str, tuple[yaml.Node, yaml.Node]]:
    if not isinstance(node, yaml.MappingNode):
        raise ConfigError("expected a mapping", path=path, line=_line(node), field=field)
    out: dict[str, tuple[yaml.Node, yaml.Node]] = {}
    for key, value in node.value:
        out[str(key.value)] = (key, value)
    return out


def _number(node: yaml.Node, path: str, field: str, key: str) -> float:
    text = node.value if isinstance(node, yaml.ScalarNode) else None
    try:
        value = float(str(text))
    except (TypeError, ValueError):
        raise ConfigError(f"expected a number, got {text!r}", path=path, line=_line(node),
                          field=field) from None
    if not math.isfinite(value):
        raise ConfigError("must be finite", path=path, line=_line(node), field=field)
    if value <= 0.0 and key not in _MAY_BE_ZERO_OR_NEGATIVE:
        raise ConfigError(f"must be > 0, got {value}", path=path, line=_line(node), field=field)
    return value


def _section(cls: type[_T], node: yaml.Node, path: str, name: str) -> _T:
    items = _mapping(node, path, name)
    wanted = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
    for key, (key_node, _) in items.items():
        if key not in wanted:
            raise ConfigError("unknown key", path=path, line=_line(key_node),
                              field=f"{name}.{key}")
    values: dict[str, float] = {}
    optional = {f.name for f in dataclasses.fields(cls)  # type: ignore[arg-type]
                if f.default is not dataclasses.MISSING}
    for key in wanted:
        if key not in items and key in optional:
            continue
        if key not in items:
            raise ConfigError("missing key", path=path, line=_line(node), field=f"{name}.{key}")
        values[key] = _number(items[key][1], path, f"{name}.{key}", key)
    return cls(**values)


def _sensors(node: yaml.Node, path: str) -> SensorParams:
    items = _mapping(node, path, "sensors")
    for key in ("sample_rate_hz", "step_s", "channels"):
        if key not in items:
            raise ConfigError("missing key", path=path, line=_line(node), field=f"sensors.{key}")
    rate = _number(items["sample_rate_hz"][1], path, "sensors.sample_rate_hz", "sample_rate_hz")
    step = _number(items["step_s"][1], path, "sensors.step_s", "step_s")
    chan_node = items["channels"][1]
    chans = _mapping(chan_node, path, "sensors.channels")
    specs: dict[str, ChannelSpec] = {}
    for name in CHANNELS:
        if name not in chans:
            raise ConfigError("missing channel", path=path, line=_line(chan_node),
                              field=f"sensors.channels.{name}")
        specs[name] = _section(ChannelSpec, chans[name][1], path, f"sensors.channels.{name}")
    for key, (key_node, _) in chans.items():
        if key not in CHANNELS:
            raise ConfigError("unknown channel", path=path, line=_line(key_node),
                              field=f"sensors.channels.{key}")
    return SensorParams(sample_rate_hz=rate, step_s=step, channels=specs)


def parse_actuator(text: str, path: str = "<string>") -> ActuatorParams:
    """Parse an actuator YAML document; raises :class:`ConfigError` naming file:line: field."""
    try:
        root = yaml.compose(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = int(mark.line) + 1 if mark is not None else None
        raise ConfigError(f"not valid YAML: {getattr(error, 'problem', error)}", path=path,
                          line=line) from None
    if root is None:
        raise ConfigError("empty file", path=path, line=1)
    items = _mapping(root, path, "<top>")
    name_item = items.get("name")
    if name_item is None or not isinstance(name_item[1], yaml.ScalarNode):
        raise ConfigError("missing or not a string", path=path, line=_line(root), field="name")
    for key, (key_node, _) in items.items():
        if key not in _SECTIONS and key not in OPTIONAL_SECTIONS and key not in ("name",
                                                                                "sensors"):
            raise ConfigError("unknown section", path=path, line=_line(key_node), field=key)
    built: dict[str, Any] = {}
    for section, cls in _SECTIONS.items():
        if section not in items:
            raise ConfigError("missing section", path=path, line=_line(root), field=section)
        built[section] = _section(cls, items[section][1], path, section)
    for section, cls in OPTIONAL_SECTIONS.items():
        if section in items:
            built[section] = _section(cls, items[section][1], path, section)
    if "sensors" not in items:
        raise ConfigError("missing section", path=path, line=_line(root), field="sensors")
    built["sensors"] = _sensors(items["sensors"][1], path)
    params = ActuatorParams(name=str(name_item[1].value), **built)
    _check_consistency(params, path)
    return params


def _check_consistency(p: ActuatorParams, path: str) -> None:
    """Cross-field checks that a per-key range cannot express."""
    if not 0.0 < p.smps.max_duty < 1.0:
        raise ConfigError("must be in (0, 1)", path=path, field="smps.max_duty")
    if not 0.0 < p.gear.efficiency <= 1.0:
        raise ConfigError("must be in (0, 1]", path=path, field="gear.efficiency")
    samples = 1.0 / (p.sensors.sample_rate_hz * p.sensors.step_s)
    if abs(samples - round(samples)) > 1e-6 or round(samples) < 1:
        raise ConfigError("1/(sample_rate_hz*step_s) must be a whole number of steps",
                          path=path, field="sensors.step_s")
    if p.bus.min_v >= p.bus.max_v:
        raise ConfigError("min_v must be below max_v", path=path, field="bus.min_v")
    if p.bit.amplitude_deg >= p.surface.travel_deg:
        raise ConfigError(f"must be below surface.travel_deg ({p.surface.travel_deg:g})",
                          path=path, field="bit.amplitude_deg")
    if p.switches.sensor_rate_hz > p.sensors.sample_rate_hz:
        raise ConfigError(f"must not exceed sensors.sample_rate_hz "
                          f"({p.sensors.sample_rate_hz:g})", path=path,
                          field="switches.sensor_rate_hz")
    if p.envelope.ambient_min_c >= p.envelope.ambient_max_c:
        raise ConfigError("ambient_min_c must be below ambient_max_c", path=path,
                          field="envelope.ambient_min_c")


def load_actuator(path: str | Path) -> ActuatorParams:
    """Load one actuator YAML file (see ``configs/actuators/``)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=str(p)) from None
    return parse_actuator(text, str(p))


def default_actuator_path() -> Path:
    """The shipped small-UAV aileron actuator file."""
    return Path(__file__).resolve().parents[2] / "configs" / "actuators" / "aileron-uav.yaml"


def with_sample_rate(params: ActuatorParams, sample_rate_hz: float) -> ActuatorParams:
    """A copy streaming sensor blocks at another rate (must divide the step rate evenly)."""
    sensors = dataclasses.replace(params.sensors, sample_rate_hz=float(sample_rate_hz))
    out = dataclasses.replace(params, sensors=sensors)
    _check_consistency(out, "<sample rate>")
    return out
