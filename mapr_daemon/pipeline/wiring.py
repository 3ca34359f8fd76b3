"""Which ICD signal is which reasoner channel: an actuator's wiring onto the bus.

The reasoner reads the plant model's channels (``phase_a_current_a``, ``position_deg``...,
:data:`~mapr_daemon.ema.params.CHANNELS`) and a few roles (the BIT request, the dynamic
pressure, the drive's own state). The bus carries them under the names its message table
gives them. The mapping lives in the daemon config, per asset (``assets[].signals``), not in
the actuator file: the actuator file is the data sheet of an actuator *type*, the same for
every unit of it, while the signal names belong to one installation's ICD. Two aileron EMAs
of one type on one bus share a data sheet and answer in different messages; the same EMA on
another aircraft keeps its data sheet and gets another ICD.

:data:`DEFAULT_SIGNALS` is the wiring of the shipped table ``configs/icd/ema-testbed.yaml``
(what the simulated aircraft puts on the bus).
"""

from __future__ import annotations

from collections.abc import Mapping

from mapr_daemon.ema.params import CHANNELS, SWITCH_CHANNELS
from mapr_daemon.icd import Icd

REQUEST = "bit_request"
"""Role: the flight control computer's BIT request (code :data:`INITIATED_BIT` starts one)."""
PRESSURE = "dynamic_pressure_pa"
"""Role: the dynamic pressure the air-data computer reports (the BIT's air load)."""
SECTOR, DUTY, DIRECTION = "commutation_sector", "pwm_duty", "drive_direction"
"""Optional roles: the drive's Hall sector, and its duty as sign-magnitude; they become the
reasoner's ``commutation_sector`` and signed ``inverter_duty`` when the bus carries them."""
REQUIRED = (*CHANNELS, REQUEST, PRESSURE)
OPTIONAL = (SECTOR, DUTY, DIRECTION, *SWITCH_CHANNELS)
"""Roles and channels an aircraft may or may not carry: the drive's state, and the power
switches' temperatures (:data:`~mapr_daemon.ema.params.SWITCH_CHANNELS`) when its EMA has
temperature-sensing switches."""
TIMEBASE = "phase_a_current_a"
"""The channel whose sample times are a BIT record's grid."""

DEFAULT_SIGNALS: dict[str, str] = {
    "dc_link_current": "dc_link_current_a", "phase_current_a": "phase_a_current_a",
    "phase_current_b": "phase_b_current_a", "phase_current_c": "phase_c_current_a",
    "dc_bus_voltage": "dc_bus_voltage_v", "surface_position": "position_deg",
    "smps_input_voltage": "smps_input_voltage_v", "smps_input_current": "smps_input_current_a",
    "smps_ripple_rms": "ripple_rms_v", "motor_temperature": "motor_temperature_c",
    "power_stage_temperature": "stage_temperature_c",
    "bit_request": REQUEST, "dynamic_pressure": PRESSURE,
    "commutation_sector": SECTOR, "pwm_duty": DUTY, "drive_direction": DIRECTION,
}
"""ICD signal -> reasoner channel or role, for ``configs/icd/ema-testbed.yaml``."""


SWITCH_SIGNALS: dict[str, str] = {
    **DEFAULT_SIGNALS, "smps_high_side_temperature": "smps_high_side_temperature_c",
    "smps_low_side_temperature": "smps_low_side_temperature_c",
    "inverter_a_high_temperature": "inverter_a_high_temperature_c"}
"""ICD signal -> reasoner channel or role, for ``configs/icd/ema-testbed-switch-temperatures.yaml``
(the shipped table with the switch temperatures in its slow block)."""


def switch_channels(signals: Mapping[str, str]) -> tuple[str, ...]:
    """The switch temperature channels a wiring carries (in
    :data:`~mapr_daemon.ema.params.SWITCH_CHANNELS` order)."""
    carried = set(signals.values())
    return tuple(c for c in SWITCH_CHANNELS if c in carried)


def problems(signals: Mapping[str, str]) -> list[tuple[str | None, str]]:
    """What is wrong with a mapping, as (ICD signal or None, problem); empty when it is whole:
    every value a known channel or role, none twice, every required one present."""
    out: list[tuple[str | None, str]] = []
    known = set(REQUIRED) | set(OPTIONAL)
    seen: dict[str, str] = {}
    for signal, channel in signals.items():
        if channel not in known:
            out.append((signal, f"{channel!r} is not a reasoner channel or role (known: "
                                f"{', '.join(sorted(known))})"))
        elif channel in seen:
            out.append((signal, f"{channel!r} is already read from {seen[channel]!r}"))
        else:
            seen[channel] = signal
    missing = [c for c in REQUIRED if c not in seen]
    if missing:
        out.append((None, f"no signal for {', '.join(missing)}"))
    return out


def not_in_icd(signals: Mapping[str, str], icd: Icd) -> list[str]:
    """The mapping's ICD signals that the table does not define."""
    names = set(icd.parameter_names)
    return [s for s in signals if s not in names]


def by_role(signals: Mapping[str, str]) -> dict[str, str]:
    """Reasoner channel or role -> ICD signal (the mapping turned round)."""
    return {channel: signal for signal, channel in signals.items()}


TWO_EMA_ELEVATOR_SIGNALS: dict[str, str] = {
    (signal if channel == PRESSURE else f"elevator_{signal}"): channel
    for signal, channel in DEFAULT_SIGNALS.items()}
"""ICD signal -> reasoner channel or role of the second actuator (the elevator EMA, RT 7) of
``configs/icd/ema-testbed-two-ema.yaml``: the aileron's names prefixed ``elevator_``, and the
air-data computer's dynamic pressure shared by both (the first actuator's wiring there is
:data:`DEFAULT_SIGNALS`)."""
