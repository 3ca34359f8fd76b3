"""Fault seeding: the paper's Table 1 faults plus motor friction, singly or compound.

A :class:`Fault` is one seeded parameter change; a run carries a tuple of them (a compound
fault when there are several). Parametric faults take the faulted parameter's value in SI
units, over the range of the paper's Table 1 (expressed as a ratio of the actuator's nominal
value so another actuator file keeps the same relative range):

==================== ========================== ============== ================= ===========
kind                 parameter                  nominal        range (Table 1)   reaction
==================== ========================== ============== ================= ===========
capacitance          smps.capacitance_f         288e-6 F       288e-6 -> 0       1)
esr                  smps.esr_ohm               0.05 ohm       0.05 -> 1.0       2)
smps_ron_high        smps.ron_high_ohm          0.2 ohm        0.2 -> 2.0        3)
smps_ron_low         smps.ron_low_ohm           0.2 ohm        0.2 -> 2.0        4)
inverter_ron_a_high  inverter.ron_a_high_ohm    0.036 ohm      0.036 -> 0.36     5)
short                one inverter switch        -              on/off            6)
open                 one inverter switch        -              on/off            7)
friction             factor on motor friction   1.0            1 -> 5            (paper III.D)
==================== ========================== ============== ================= ===========

``short`` and ``open`` take a switch name (``A_high``, ``A_low``, ``B_high``, ... ``C_low``)
instead of a number; several switches may be faulted at once ("multi-phase").

Text form, as the CLI reads it: ``esr=0.5``, ``capacitance=72e-6``, ``short=A_high``,
``esr@0.25`` (a quarter of the way from nominal to the end of the range).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError

SWITCHES: tuple[str, ...] = ("A_high", "A_low", "B_high", "B_low", "C_high", "C_low")
"""Inverter switch names: phase then side."""


@dataclasses.dataclass(frozen=True)
class FaultRange:
    """A parametric fault: which parameter, and where its range ends relative to nominal."""

    kind: str
    parameter: str
    end_ratio: float
    unit: str
    reaction: str


PARAMETRIC: dict[str, FaultRange] = {
    r.kind: r for r in (
        FaultRange("capacitance", "smps.capacitance_f", 0.0, "F",
                   "slower 24 V start-up, less impulse current, inverter input instability"),
        FaultRange("esr", "smps.esr_ohm", 20.0, "ohm", "more 24 V ripple"),
        FaultRange("smps_ron_high", "smps.ron_high_ohm", 10.0, "ohm", "SMPS output instability"),
        FaultRange("smps_ron_low", "smps.ron_low_ohm", 10.0, "ohm", "SMPS output instability"),
        FaultRange("inverter_ron_a_high", "inverter.ron_a_high_ohm", 10.0, "ohm",
                   "less phase current, worse position tracking"),
        FaultRange("friction", "motor friction factor", 5.0, "x",
                   "more current for the same motion"),
    )
}
TERMINAL: tuple[str, ...] = ("short", "open")
KINDS: tuple[str, ...] = (*PARAMETRIC, *TERMINAL)


@dataclasses.dataclass(frozen=True)
class Fault:
    """One seeded fault: ``value`` for parametric kinds, ``switch`` for short/open."""

    kind: str
    value: float = 0.0
    switch: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigError(f"unknown fault kind (known: {', '.join(KINDS)})", field="fault")
        if self.kind in TERMINAL and self.switch not in SWITCHES:
            raise ConfigError(f"switch must be one of {', '.join(SWITCHES)}", field=self.kind)
        if self.kind in PARAMETRIC and self.value < 0.0:
            raise ConfigError("must be >= 0", field=self.kind)

    def label(self) -> str:
        """Text form, parseable by :func:`parse_fault`."""
        if self.kind in TERMINAL:
            return f"{self.kind}={self.switch}"
        return f"{self.kind}={self.value:g}"


def nominal_value(params: ActuatorParams, kind: str) -> float:
    """The healthy value of a parametric fault's parameter."""
    if kind == "capacitance":
        return params.smps.capacitance_f
    if kind == "esr":
        return params.smps.esr_ohm
    if kind == "smps_ron_high":
        return params.smps.ron_high_ohm
    if kind == "smps_ron_low":
        return params.smps.ron_low_ohm
    if kind == "inverter_ron_a_high":
        return params.inverter.ron_a_high_ohm
    if kind == "friction":
        return 1.0
    raise ConfigError("not a parametric fault kind", field=kind)


def range_end(params: ActuatorParams, kind: str) -> float:
    """The worst value of the kind's Table 1 range for this actuator."""
    return nominal_value(params, kind) * PARAMETRIC[kind].end_ratio


def at_severity(params: ActuatorParams, kind: str, severity: float) -> Fault:
    """A parametric fault ``severity`` of the way (0 = nominal, 1 = end of range)."""
    if not 0.0 <= severity <= 1.0:
        raise ConfigError("severity must be in [0, 1]", field=kind)
    lo, hi = nominal_value(params, kind), range_end(params, kind)
    return Fault(kind, lo + severity * (hi - lo))


def severity_of(params: ActuatorParams, fault: Fault) -> float:
    """Where a fault sits in its range (1.0 for short/open)."""
    if fault.kind in TERMINAL:
        return 1.0
    lo, hi = nominal_value(params, fault.kind), range_end(params, fault.kind)
    return (fault.value - lo) / (hi - lo)


def parse_fault(text: str, params: ActuatorParams) -> Fault:
    """``kind=value``, ``kind@severity`` or ``short=A_high``; raises ConfigError otherwise."""
    if "@" in text:
        kind, _, sev = text.partition("@")
        try:
            return at_severity(params, kind.strip(), float(sev))
        except ValueError:
            raise ConfigError(f"bad severity {sev!r}", field=kind) from None
        except KeyError:
            raise ConfigError("not a parametric fault kind", field=kind) from None
    kind, sep, value = text.partition("=")
    kind = kind.strip()
    if not sep:
        raise ConfigError("expected kind=value or kind@severity", field=text)
    if kind in TERMINAL:
        return Fault(kind, switch=value.strip())
    try:
        return Fault(kind, float(value))
    except ValueError:
        raise ConfigError(f"bad value {value!r}", field=kind) from None


@dataclasses.dataclass(frozen=True)
class FaultSet:
    """The faults of one run (empty = healthy), after checking they do not contradict."""

    faults: tuple[Fault, ...] = ()

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for f in self.faults:
            key = f"{f.kind}:{f.switch}" if f.kind in TERMINAL else f.kind
            if key in seen:
                raise ConfigError("the same fault twice in one run", field=key)
            seen.add(key)
        shorts = {f.switch for f in self.faults if f.kind == "short"}
        opens = {f.switch for f in self.faults if f.kind == "open"}
        if shorts & opens:
            raise ConfigError("a switch cannot be both short and open", field="fault")

    @classmethod
    def of(cls, faults: Iterable[Fault]) -> FaultSet:
        return cls(tuple(faults))

    def label(self) -> str:
        return "+".join(f.label() for f in self.faults) or "healthy"

    def value(self, kind: str, default: float) -> float:
        for f in self.faults:
            if f.kind == kind:
                return f.value
        return default

    def switches(self, kind: str) -> tuple[str, ...]:
        return tuple(f.switch for f in self.faults if f.kind == kind)


def apply(params: ActuatorParams, faults: FaultSet) -> ActuatorParams:
    """A copy of ``params`` with the parametric faults applied (short/open act in the plant)."""
    smps = dataclasses.replace(
        params.smps,
        capacitance_f=faults.value("capacitance", params.smps.capacitance_f),
        esr_ohm=faults.value("esr", params.smps.esr_ohm),
        ron_high_ohm=faults.value("smps_ron_high", params.smps.ron_high_ohm),
        ron_low_ohm=faults.value("smps_ron_low", params.smps.ron_low_ohm),
    )
    inverter = dataclasses.replace(
        params.inverter,
        ron_a_high_ohm=faults.value("inverter_ron_a_high", params.inverter.ron_a_high_ohm),
    )
    factor = faults.value("friction", 1.0)
    motor = dataclasses.replace(
        params.motor,
        viscous_friction_nm_s=params.motor.viscous_friction_nm_s * factor,
        coulomb_friction_nm=params.motor.coulomb_friction_nm * factor,
    )
    return dataclasses.replace(params, smps=smps, inverter=inverter, motor=motor)
