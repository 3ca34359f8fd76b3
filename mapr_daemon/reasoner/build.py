"""Build a fault dictionary from fault-seeded BIT runs, and calibrate its thresholds.

One batch holds every run: at each dictionary pressure, ``nominal_per_pressure`` healthy runs
(their spread is the noise model), each parametric kind at each severity, each short and each
open switch; plus ``calibration_runs`` healthy runs at random pressures *between* the grid
points, with their own seeds, which set the anomaly thresholds (the largest healthy score times
``threshold_margin``), so the threshold also covers the pressure interpolation error.

>>> # d = build(load_actuator(default_actuator_path()), DictionarySpec())
>>> # d.save("dictionary.npz")
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mapr_daemon.ema.faults import PARAMETRIC, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import classifier, curves
from mapr_daemon.reasoner.corpus import Runs, simulate_bit
from mapr_daemon.reasoner.dictionary import (
    Dictionary,
    DictionarySpec,
    PaperCurve,
    Template,
    pressure_weights,
)
from mapr_daemon.reasoner.features import (
    EXTENDED_SIGNALS,
    FloatArray,
    WindowSpec,
    column_names,
    derived_signals,
    feature_matrix,
)

PAPER_THRESHOLD_SD = 3.0
"""A paper curve's threshold is at least this many healthy spreads of its cell."""
SD_FLOOR_COLUMN = 0.1
"""Floor of a cell's healthy spread: this share of its column's median spread over windows."""
SD_FLOOR_REL = 0.01
"""... and this share of the column's typical magnitude: quiet windows (a held position, a
spectrum of pure quantisation noise) have nearly zero spread, which would make any LSB flip
look like an anomaly."""


def run_matrices(runs: Runs, starts: np.ndarray, length: int) -> FloatArray:
    """M ``(n, 32, 72)`` of every run."""
    sig = derived_signals(runs.channels, runs.command_deg)
    return feature_matrix(sig, starts, length, runs.sample_rate_hz, EXTENDED_SIGNALS)


def _plan(params: ActuatorParams, spec: DictionarySpec) -> tuple[list[FaultSet], list[float],
                                                                 list[int], list[str]]:
    """Fault sets, pressures, seeds and a role tag for every run of the build batch."""
    for k in spec.kinds:
        if k not in PARAMETRIC:
            raise ConfigError(f"not a parametric fault kind: {k}", field="kinds")
    if len(spec.pressures_pa) < 1 or spec.nominal_per_pressure < 2:
        raise ConfigError("need pressures and >= 2 nominal runs per pressure", field="spec")
    fs: list[FaultSet] = []
    qs: list[float] = []
    seeds: list[int] = []
    roles: list[str] = []
    seed = spec.seed_base

    def add(f: FaultSet, q: float, role: str) -> None:
        nonlocal seed
        fs.append(f)
        qs.append(q)
        seeds.append(seed)
        roles.append(role)
        seed += 1

    for q in spec.pressures_pa:
        for _ in range(spec.nominal_per_pressure):
            add(FaultSet(), q, f"nominal@{q:g}")
        for kind in spec.kinds:
            for s in spec.severities:
                add(FaultSet.of([at_severity(params, kind, s)]), q, f"{kind}@{q:g}")
        for sw in spec.shorts:
            add(FaultSet.of([Fault("short", switch=sw)]), q, f"short:{sw}@{q:g}")
        for sw in spec.opens:
            add(FaultSet.of([Fault("open", switch=sw)]), q, f"open:{sw}@{q:g}")
    rng = np.random.default_rng(spec.seed_base + 7919)
    lo, hi = spec.calibration_pressure_pa
    for q in rng.uniform(lo, hi, spec.calibration_runs):
        add(FaultSet(), float(q), "calibration")
    return fs, qs, seeds, roles


def build(params: ActuatorParams, spec: DictionarySpec,
          progress: Callable[[float], None] | None = None) -> Dictionary:
    """Simulate, extract M, keep the nominal statistics and templates, calibrate."""
    fs, qs, seeds, roles = _plan(params, spec)
    runs = simulate_bit(params, fs, qs, seeds, progress=progress)
    win = WindowSpec(spec.window_samples)
    starts = win.starts(runs.corners, runs.command_deg.size)
    m = run_matrices(runs, starts, win.length)
    return assemble(params, spec, m, runs.dynamic_pressure_pa, roles, starts,
                    runs.sample_rate_hz)


def assemble(params: ActuatorParams, spec: DictionarySpec, m: FloatArray, q: FloatArray,
             roles: list[str], starts: np.ndarray, sample_rate_hz: float) -> Dictionary:
    """The dictionary from already computed matrices (split out so tests can reuse a batch)."""
    grid = np.asarray(spec.pressures_pa, dtype=np.float64)
    role = np.asarray(roles)
    nom = np.stack([m[role == f"nominal@{q:g}"].mean(axis=0) for q in spec.pressures_pa])
    resid = np.concatenate([m[role == f"nominal@{q:g}"] - nom[k]
                            for k, q in enumerate(spec.pressures_pa)])
    dof = resid.shape[0] - grid.size
    sd = np.sqrt((resid**2).sum(axis=0) / max(dof, 1))
    floor = np.maximum(SD_FLOOR_COLUMN * np.median(sd, axis=0),
                       SD_FLOOR_REL * np.median(np.abs(nom), axis=(0, 1)))
    sd = np.maximum(sd, np.maximum(floor, 1e-9)[None, :])
    templates: list[Template] = []
    tpl_m: list[FloatArray] = []
    for kind in spec.kinds:
        vals = tuple(at_severity(params, kind, s).value for s in spec.severities)
        templates.append(Template(kind, kind, "", spec.severities, vals, PARAMETRIC[kind].unit))
        tpl_m.append(np.stack([m[role == f"{kind}@{q:g}"] for q in spec.pressures_pa]))
    for kind, switches in (("short", spec.shorts), ("open", spec.opens)):
        for sw in switches:
            templates.append(Template(f"{kind}:{sw}", kind, sw, (1.0,), (1.0,), "on/off"))
            tpl_m.append(np.stack([m[role == f"{kind}:{sw}@{q:g}"] for q in spec.pressures_pa]))
    d = Dictionary(actuator=params.name, sample_rate_hz=sample_rate_hz,
                   window_samples=spec.window_samples, window_starts=starts,
                   signals=EXTENDED_SIGNALS, columns=tuple(column_names(EXTENDED_SIGNALS)),
                   pressures_pa=grid, nominal_mean=nom, nominal_sd=sd, templates=templates,
                   template_m=tpl_m, paper={})
    d.paper = paper_curves(d)
    calib = role == "calibration"
    calibrate(d, m[calib], q[calib], spec.threshold_margin)
    return d


def paper_curves(d: Dictionary, reference_pressure: int = 0) -> dict[str, PaperCurve]:
    """G, V and the chosen curve per parametric kind on the paper's 32 x 32 M.

    The curve is chosen at the reference pressure (the paper's ground bench) on N scaled by
    the healthy spread; its N is then kept at every pressure for the classifier.
    """
    out: dict[str, PaperCurve] = {}
    cols = classifier.PAPER_COLUMNS
    for t, tm in zip(d.templates, d.template_m, strict=True):
        if t.switch:
            continue
        nom = d.nominal_mean[:, :, :cols]
        n_all = curves.distance(tm[:, :, :, :cols], nom[:, None])  # (K, S, W, 32)
        n_all = np.concatenate([np.zeros_like(n_all[:, :1]), n_all], axis=1)
        k = reference_pressure
        g = curves.good_times(n_all[k, 1:])
        v = curves.final_values(n_all[k, 1:], g)
        if v.shape[0] == 0:
            continue
        c = curves.chosen_curve(v, scale=d.nominal_sd[:, :cols])
        out[t.kind] = PaperCurve(t.kind, g, v, c.row, c.col, c.reference,
                                 n_all[:, :, c.row, c.col], math.inf)
    return out


def calibrate(d: Dictionary, m: FloatArray, q: FloatArray, margin: float) -> None:
    """Thresholds from healthy runs: ours (GLR score) and the paper's (per-curve N)."""
    if m.shape[0] < 2:
        raise ConfigError("need >= 2 calibration runs", field="calibration_runs")
    scores = []
    for i in range(m.shape[0]):
        z = classifier.zscores(d, m[i], float(q[i]))
        scores.append(classifier.glr_score(z, classifier.fit_templates(
            d, z, classifier.signatures(d, float(q[i])))))
    s = np.asarray(scores)
    d.threshold = float(s.max() * margin)
    d.score_spread = float(max(s.std(), 1e-6))
    d.log_score_spread = float(max(np.log(np.maximum(s, 1e-9)).std(), 0.05))
    d.calibration = {"runs": float(s.size), "score_max": float(s.max()),
                     "score_median": float(np.median(s)), "margin": margin}
    for c in d.paper.values():
        w = np.stack([np.tensordot(pressure_weights(d.pressures_pa, float(qi)),
                                   d.nominal_mean, axes=1) for qi in q])
        n = np.abs(m[:, c.row, c.col] - w[:, c.row, c.col])
        floor = PAPER_THRESHOLD_SD * float(d.nominal_sd[c.row, c.col])
        object.__setattr__(c, "threshold", float(max(n.max() * margin, floor)))

