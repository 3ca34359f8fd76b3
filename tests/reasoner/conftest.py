"""One small batch shared by the reasoner tests: a tiny dictionary plus held-out runs.

Everything is simulated together (one plant batch, ~20 s on two cores); the dictionary is
assembled from its share of the runs, and the held-out runs (other seeds, other pressures,
magnitudes between the dictionary's) are what the classifier tests decide on.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import Fault, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit

SPEC = DictionarySpec(
    pressures_pa=(0.0, 800.0, 1600.0), nominal_per_pressure=4, severities=(0.25, 0.5, 0.75, 1.0),
    kinds=("esr", "friction"), shorts=("A_high",), opens=("A_high",), seeds_per_point=2,
    healthy_runs=100, calibration_runs=12, record_pool=3, calibration_pressure_pa=(200.0, 1400.0),
    threshold_margin=1.5, subspace_dims=8, knots=(0.0, 0.5, 1.0))

HELD_OUT: list[tuple[str, float, float]] = [
    ("healthy", 0.0, 700.0), ("healthy", 0.0, 1100.0), ("healthy", 0.0, 300.0),
    ("esr", 0.6, 900.0), ("friction", 0.8, 500.0), ("friction", 0.4, 1200.0),
    ("short", 1.0, 800.0), ("open", 1.0, 1000.0),
]
"""(kind, severity, dynamic pressure) of the held-out runs."""


@dataclasses.dataclass
class Bench:
    params: ActuatorParams
    dictionary: Dictionary
    runs: Runs
    m: FloatArray
    held_m: FloatArray
    held_q: FloatArray


def _held_faults(params: ActuatorParams) -> list[FaultSet]:
    out = []
    for kind, sev, _ in HELD_OUT:
        if kind == "healthy":
            out.append(FaultSet())
        elif kind in ("short", "open"):
            out.append(FaultSet.of([Fault(kind, switch="A_high")]))
        else:
            out.append(FaultSet.of([at_severity(params, kind, sev)]))
    return out


@pytest.fixture(scope="session")
def bench() -> Bench:
    params = load_actuator(default_actuator_path())
    plan = dictionary_build._plan(params, SPEC)
    fs, qs, seeds, roles = plan.faults, plan.pressures_pa, plan.seeds, plan.roles
    held = _held_faults(params)
    fs += held
    qs += [q for _, _, q in HELD_OUT]
    seeds += [50_000 + i for i in range(len(held))]
    roles += ["held"] * len(held)
    runs = simulate_bit(params, fs, qs, seeds,
                        ambient_c=plan.ambient_c + [None] * len(held),
                        bus_v=plan.bus_v + [None] * len(held))
    starts = dictionary_build.windows(SPEC, runs.corners, runs.command_deg.size)
    m = dictionary_build.run_matrices(runs, starts, SPEC.window_samples)
    role = np.asarray(roles)
    own = role != "held"
    d = dictionary_build.assemble(params, SPEC, m[own], runs.dynamic_pressure_pa[own],
                       [r for r in roles if r != "held"], starts, runs.sample_rate_hz)
    return Bench(params, d, runs, m, m[role == "held"], runs.dynamic_pressure_pa[role == "held"])


def commissioned_folder(bench: Bench, folder: Path, count: int = 6,
                        detector: bool = False, allowance: bool = False) -> Path:
    """A ``mapr commission`` folder made from the first ``count`` of the bench's own healthy
    runs (the unit is the data sheet's twin: what the callers test is the reading's wiring,
    not what the discrepancy learns): the actuator, the learned discrepancy and the record;
    with ``detector``, the unit's anomaly detector calibrated on the same runs (a record
    written before there was one has none), with its single-fault allowance if ``allowance``
    (about 40 readings more)."""
    from mapr_daemon.ema.dump import write_actuator
    from mapr_daemon.reasoner.commissioning import detector as det
    from mapr_daemon.reasoner.commissioning.bits import from_runs
    from mapr_daemon.reasoner.commissioning.discrepancy import learn_unit

    own = bench.runs.n - len(HELD_OUT)
    healthy = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:count]
    write_actuator(folder / "actuator.yaml", bench.params)
    bits = from_runs(bench.runs, "bench", healthy)
    disc = learn_unit(bench.params, bits, 10)
    disc.save(folder / "discrepancy.npz")
    record = {"format": "mapr-commissioning/1", "created": "2025-01-01T00:00:00+00:00",
              "actuator": bench.params.name, "datasheet": "sheet.yaml",
              "identified_actuator": "actuator.yaml", "dictionary": None, "parameters": [],
              "tolerances": [], "residual_rms": {"before": {}, "after": {}}, "bits": [],
              "skipped": [], "correlation": [],
              "fit": {"iterations": 3, "converged": True, "model_runs": 10, "wall_s": 1.0},
              "discrepancy": {"file": "discrepancy.npz"}}
    if detector:
        record["detector"] = det.calibrate(bench.params, bench.params, disc, bits,
                                           allowance=allowance).to_json()
    (folder / "commissioning.json").write_text(json.dumps(record))
    return folder
