"""The ``.npz`` run format of ``mapr simulate``, readable with numpy alone (no pickle).

Arrays (``R`` runs, ``N`` samples, ``F`` = most faults in one run; see docs/simulate.md):

* ``time_s`` ``(N,)`` — sample times, seconds from the start of the run.
* ``ch_<channel>`` ``(R, N)`` — sensor channels as the ADC gives them (noise, quantisation).
* ``truth_<signal>`` ``(R, N)`` — noise-free block means (true position, torque, duty, ...).
* ``in_<input>`` ``(R, N)`` — the profile: command and air data each run saw.
* ``run_label`` ``(R,)``, ``seed`` ``(R,)``, ``condition`` ``(R,)`` — per-run identity.
* ``fault_kind``, ``fault_switch`` ``(R, F)`` (``""`` pads), ``fault_value``,
  ``fault_severity`` ``(R, F)`` (NaN pads) — ground truth of the seeded faults.
* ``meta_json`` — a 0-d string: format version, actuator, sample rate, step, units.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mapr_daemon.ema.faults import TERMINAL, severity_of
from mapr_daemon.ema.run import RunResult

FORMAT = "mapr-sim/1"
INPUTS = ("command_deg", "altitude_m", "airspeed_mps", "density_kg_m3", "dynamic_pressure_pa")
UNITS = {
    "dc_link_current_a": "A", "phase_a_current_a": "A", "phase_b_current_a": "A",
    "phase_c_current_a": "A", "dc_bus_voltage_v": "V", "position_deg": "deg",
    "motor_temperature_c": "degC", "smps_input_voltage_v": "V", "smps_input_current_a": "A",
    "stage_temperature_c": "degC", "ripple_rms_v": "V rms",
    "commutation_sector": "sector 1-6", "inverter_duty": "fraction of the PWM period, signed",
}


def to_arrays(results: Sequence[RunResult], meta: dict[str, Any]) -> dict[str, np.ndarray]:
    """Stack results sharing one time base (e.g. one per flight condition) into arrays."""
    first = results[0]
    n = first.time_s.size
    out: dict[str, np.ndarray] = {"time_s": first.time_s}
    for name in first.channels:
        out[f"ch_{name}"] = np.concatenate([r.channels[name][:, :n] for r in results])
    for name in first.truth:
        out[f"truth_{name}"] = np.concatenate([r.truth[name][:, :n] for r in results])
    for name in INPUTS:
        rows = [np.broadcast_to(getattr(r.profile, name)[:n], (len(r.specs), n)) for r in results]
        out[f"in_{name}"] = np.concatenate(rows)
    specs = [(r, s) for r in results for s in r.specs]
    width = max(1, max(len(s.faults.faults) for _, s in specs))
    kind = np.full((len(specs), width), "", dtype="<U24")
    switch = np.full((len(specs), width), "", dtype="<U8")
    value = np.full((len(specs), width), np.nan)
    sev = np.full((len(specs), width), np.nan)
    for row, (_, s) in enumerate(specs):
        for col, f in enumerate(s.faults.faults):
            kind[row, col] = f.kind
            switch[row, col] = f.switch
            value[row, col] = 1.0 if f.kind in TERMINAL else f.value
            sev[row, col] = severity_of(s.params, f)
    out.update(
        run_label=np.array([s.faults.label() for _, s in specs]),
        seed=np.array([s.seed for _, s in specs], dtype=np.int64),
        condition=np.array([r.profile.name for r, _ in specs]),
        fault_kind=kind, fault_switch=switch, fault_value=value, fault_severity=sev,
        meta_json=np.array(json.dumps({"format": FORMAT, "units": UNITS, **meta})),
    )
    return out


def save(path: str | Path, results: Sequence[RunResult], meta: dict[str, Any]) -> None:
    """Write results as one compressed ``.npz``."""
    np.savez_compressed(Path(path), **to_arrays(results, meta))  # type: ignore[arg-type]


def load(path: str | Path) -> dict[str, np.ndarray]:
    """Read a file written by :func:`save` (plain numpy, no pickle)."""
    with np.load(Path(path), allow_pickle=False) as data:
        return {k: data[k] for k in data.files}
