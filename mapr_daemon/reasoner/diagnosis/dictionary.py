"""The fault dictionary: what a build spec asks for and what a built dictionary holds.

A dictionary is built (:mod:`mapr_daemon.reasoner.training.dictionary_build`) from fault-seeded BIT
runs at a few
dynamic pressures, and stored as one versioned ``.npz`` (numpy only, no pickle):

* ``nominal_mean`` ``(K, W, C)`` — M of the healthy actuator at each of the K pressures;
* ``nominal_sd`` ``(W, C)`` — the healthy spread (seeds: sensor noise, aircraft-bus voltage,
  ambient temperature, friction scatter), pooled over the pressures;
* ``tpl_<i>`` ``(K, S, 32, 32)`` — the paper's M of template i (one fault kind, or one switch
  for short/open) at each pressure and severity;
* ``healthy_*`` — our healthy model (:mod:`~mapr_daemon.reasoner.diagnosis.healthy_model`),
``fm_*`` the
  fault signatures in its subspace (:mod:`~mapr_daemon.reasoner.diagnosis.fault_models`);
* ``paper_<kind>_G`` / ``_V`` / ``_curve`` — the paper's good-times and final-values matrices
  at the reference pressure and the chosen curve's N at every pressure;
* ``meta_json`` — format version, actuator, windows, signals, columns, pressures, templates,
  calibrated thresholds.

M has W windows and C = 96 columns
(:data:`~mapr_daemon.reasoner.diagnosis.features.EXTENDED_SIGNALS`):
its first 32 rows are the corner windows and its first 32 columns the paper's signals (the
paper's 32 x 32 M); the further rows tile the whole record (our healthy model's cells).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError, RecordError
from mapr_daemon.reasoner.diagnosis.detection_map import DetectionMap
from mapr_daemon.reasoner.diagnosis.fault_models import FaultModels
from mapr_daemon.reasoner.diagnosis.features import (
    derived_signals,
    feature_matrix,
    missing_sources,
)
from mapr_daemon.reasoner.diagnosis.healthy_model import HealthyModel, pressure_weights

FORMAT = "mapr-dictionary/4"
"""3: the sector-resolved phase-A loop resistance is a signal (one healthy-model cell);
4: the healthy model's physical regressors (ground, dropout, ESR's temperature law) and its
condition-dependent spread."""
__all__ = ["FORMAT", "Dictionary", "DictionarySpec", "PaperCurve", "Template", "pressure_weights"]


@dataclasses.dataclass(frozen=True)
class DictionarySpec:
    """What to simulate for a dictionary (configs/reasoner/dictionary.yaml)."""

    pressures_pa: tuple[float, ...] = (0.0, 500.0, 1000.0, 1500.0, 2000.0, 2500.0)
    nominal_per_pressure: int = 8
    severities: tuple[float, ...] = (0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0)
    kinds: tuple[str, ...] = ("capacitance", "esr", "smps_ron_high", "smps_ron_low",
                              "inverter_ron_a_high", "friction")
    shorts: tuple[str, ...] = ("A_high", "A_low", "B_high", "B_low", "C_high", "C_low")
    opens: tuple[str, ...] = ("A_high", "A_low", "B_high", "B_low", "C_high", "C_low")
    seeds_per_point: int = 1
    """Runs per (pressure, severity) of a parametric kind (their mean is the paper's M)."""
    healthy_runs: int = 48
    """Healthy runs at random pressures that, with the grid's nominal runs, fit the healthy
    model (ours)."""
    calibration_runs: int = 48
    calibration_pressure_pa: tuple[float, float] = (0.0, 2500.0)
    detection_map_runs: int = 6
    """Per parametric kind and cell of the detection map (bus voltage x ambient bands over the
    actuator's envelope, :mod:`~mapr_daemon.reasoner.diagnosis.detection_map`), runs at random
    severities (25-100 % of range); 0 builds a dictionary without a map."""
    fault_calibration_runs: int = 8
    """Per parametric kind, runs at random severities (25-100 % of range), pressures and
    conditions that fit nothing: what a correct explanation leaves and what a second fault
    gains on a single one (the thresholds of
    :mod:`~mapr_daemon.reasoner.diagnosis.compound`); 0 builds a dictionary that names no
    pairs."""
    envelope: bool = False
    """Every run's ambient temperature and bus mean drawn over the actuator's envelope, the
    healthy and calibration runs' pressures up to its maximum (else the plant's own draws
    around the file's values and ``calibration_pressure_pa``)."""
    ground_share: float = 0.0
    """Share of the healthy and calibration runs flown on the ground (0 Pa)."""
    window_samples: int = 32
    record_skip_samples: int = 32
    """Our record rows tile the record after this many samples."""
    record_pool: int = 1
    """Our healthy model's cells average this many consecutive record rows."""
    threshold_margin: float = 1.5
    """The paper classifier's thresholds: largest healthy calibration N times this."""
    false_alarm_rate: float = 1.0e-4
    """Ours: the per-BIT probability that a healthy actuator is flagged."""
    subspace_dims: int = 32
    shrinkage_floor: float = 0.0
    """Least covariance shrinkage of the healthy model (Ledoit-Wolf's estimate if larger)."""
    knots: tuple[float, ...] = (0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0)
    seed_base: int = 0
    switch_temperatures: bool = False
    """Build with the power switches' temperatures
    (:data:`~mapr_daemon.reasoner.diagnosis.features.SWITCH_SIGNALS`): for an actuator whose
    EMA carries them on the bus; its records must then carry them too."""

    @classmethod
    def load(cls, path: str | Path) -> DictionarySpec:
        """Read a spec YAML; unknown keys are errors (a typo must not pass silently)."""
        p = Path(path)
        try:
            raw = yaml.safe_load(p.read_text(encoding="utf-8")) or {}
        except OSError as error:
            raise ConfigError(f"cannot read: {error.strerror}", path=str(p)) from None
        except yaml.YAMLError as error:
            raise ConfigError(f"not valid YAML: {error}", path=str(p)) from None
        if not isinstance(raw, dict):
            raise ConfigError("a dictionary spec is a mapping", path=str(p))
        fields = {f.name: f for f in dataclasses.fields(cls)}
        kwargs: dict[str, Any] = {}
        for key, value in raw.items():
            if key not in fields:
                raise ConfigError(f"unknown key (known: {', '.join(fields)})", path=str(p),
                                  field=str(key))
            default = getattr(cls(), key)
            kwargs[key] = tuple(value) if isinstance(default, tuple) else type(default)(value)
        return cls(**kwargs)


@dataclasses.dataclass(frozen=True)
class Template:
    """One dictionary entry: a parametric fault kind over severities, or one faulted switch."""

    name: str
    kind: str
    switch: str
    severities: tuple[float, ...]
    values: tuple[float, ...]
    unit: str


@dataclasses.dataclass(frozen=True)
class PaperCurve:
    """The paper's curve for one fault kind: G and V at the reference pressure, chosen cell."""

    kind: str
    g: np.ndarray
    v: FloatArray
    row: int
    col: int
    reference: int
    curve: FloatArray
    """N of the chosen cell, ``(K, S+1)`` (severity 0 first) at every pressure."""
    threshold: float


@dataclasses.dataclass
class Dictionary:
    """A built fault dictionary (see the module docstring for the arrays)."""

    actuator: str
    sample_rate_hz: float
    window_samples: int
    window_starts: np.ndarray
    signals: tuple[str, ...]
    columns: tuple[str, ...]
    pressures_pa: FloatArray
    nominal_mean: FloatArray
    nominal_sd: FloatArray
    templates: list[Template]
    template_m: list[FloatArray]
    paper: dict[str, PaperCurve]
    healthy: HealthyModel | None = None
    models: FaultModels | None = None
    threshold: float = float("inf")
    score_spread: float = 1.0
    log_score_spread: float = 1.0
    calibration: dict[str, float] = dataclasses.field(default_factory=dict)
    detection: DetectionMap | None = None
    """Where on the envelope each mode is seen (None: built without a map)."""

    @property
    def paper_rows(self) -> int:
        """M's first rows, the paper's corner windows (the rest tile the record)."""
        return min(32, int(self.window_starts.size))

    def record_matrix(self, channels: Mapping[str, FloatArray],
                      command_deg: FloatArray) -> FloatArray:
        """M ``(W, C)`` of one BIT record, read with this dictionary's windows and signals;
        RecordError if the record is shorter than its last window."""
        need = int(self.window_starts.max()) + self.window_samples
        n = int(np.asarray(channels["position_deg"]).shape[-1])
        if n < need:
            raise RecordError(f"a BIT record needs {need} samples, got {n}", field="signals")
        lacking = missing_sources(self.signals, tuple(channels))
        if lacking:
            raise RecordError("the dictionary was built with the switch temperatures; the "
                              f"record has no {', '.join(lacking)}", field="signals")
        sig = derived_signals({k: np.atleast_2d(np.asarray(v, dtype=np.float64))
                               for k, v in channels.items()},
                              np.asarray(command_deg, dtype=np.float64))
        m: FloatArray = feature_matrix(sig, self.window_starts, self.window_samples,
                                       self.sample_rate_hz, self.signals)[0]
        return m

    def save(self, path: str | Path) -> None:
        """Write the versioned ``.npz``."""
        arrays: dict[str, np.ndarray] = {
            "nominal_mean": self.nominal_mean, "nominal_sd": self.nominal_sd,
            "pressures_pa": self.pressures_pa, "window_starts": self.window_starts,
        }
        for i, m in enumerate(self.template_m):
            arrays[f"tpl_{i}"] = m
        if self.healthy is not None and self.models is not None:
            arrays.update(self.healthy.arrays())
            arrays.update(self.models.arrays())
        for kind, c in self.paper.items():
            arrays[f"paper_{kind}_G"] = c.g
            arrays[f"paper_{kind}_V"] = c.v
            arrays[f"paper_{kind}_curve"] = c.curve
        meta = {
            "format": FORMAT, "actuator": self.actuator, "sample_rate_hz": self.sample_rate_hz,
            "window_samples": self.window_samples, "signals": list(self.signals),
            "columns": list(self.columns),
            "templates": [dataclasses.asdict(t) for t in self.templates],
            "paper": {k: {"row": c.row, "col": c.col, "reference": c.reference,
                          "threshold": c.threshold} for k, c in self.paper.items()},
            "threshold": self.threshold, "score_spread": self.score_spread,
            "log_score_spread": self.log_score_spread, "calibration": self.calibration,
        }
        if self.detection is not None:
            meta["detection_map"] = self.detection.as_json()
        arrays["meta_json"] = np.array(json.dumps(meta))
        np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]

    @classmethod
    def load(cls, path: str | Path) -> Dictionary:
        """Read a dictionary; ConfigError if it is missing, corrupt or of another version."""
        p = Path(path)
        try:
            with np.load(p, allow_pickle=False) as data:
                a = {k: data[k] for k in data.files}
        except (OSError, ValueError) as error:
            raise ConfigError(f"cannot read dictionary: {error}", path=str(p)) from None
        try:
            meta = json.loads(str(a["meta_json"]))
        except (KeyError, json.JSONDecodeError):
            raise ConfigError("not a MAPR dictionary (no meta_json)", path=str(p)) from None
        if meta.get("format") != FORMAT:
            raise ConfigError(f"dictionary format {meta.get('format')!r}, expected {FORMAT!r}"
                              " (rebuild it with `mapr dictionary build`)", path=str(p))
        templates = [Template(t["name"], t["kind"], t["switch"], tuple(t["severities"]),
                              tuple(t["values"]), t["unit"]) for t in meta["templates"]]
        paper = {k: PaperCurve(k, a[f"paper_{k}_G"], a[f"paper_{k}_V"], int(c["row"]),
                               int(c["col"]), int(c["reference"]), a[f"paper_{k}_curve"],
                               float(c["threshold"])) for k, c in meta["paper"].items()}
        healthy = HealthyModel.from_arrays(a) if "healthy_coef" in a else None
        models = (FaultModels.from_arrays(a, len(templates), a["pressures_pa"])
                  if "fm_knots" in a else None)
        return cls(
            actuator=meta["actuator"], sample_rate_hz=float(meta["sample_rate_hz"]),
            window_samples=int(meta["window_samples"]), window_starts=a["window_starts"],
            signals=tuple(meta["signals"]), columns=tuple(meta["columns"]),
            pressures_pa=a["pressures_pa"], nominal_mean=a["nominal_mean"],
            nominal_sd=a["nominal_sd"], templates=templates,
            template_m=[a[f"tpl_{i}"] for i in range(len(templates))], paper=paper,
            healthy=healthy, models=models, threshold=float(meta["threshold"]),
            score_spread=float(meta["score_spread"]),
            log_score_spread=float(meta["log_score_spread"]),
            calibration={k: float(v) for k, v in meta["calibration"].items()},
            detection=(DetectionMap.from_json(meta["detection_map"])
                       if "detection_map" in meta else None))
