"""Build a fault dictionary from fault-seeded BIT runs, and calibrate its thresholds.

One batch holds every run, each with its own seed (sensor noise, aircraft-bus voltage, ambient
temperature, friction scatter): at each dictionary pressure, ``nominal_per_pressure`` healthy
runs, each parametric kind at each severity (``seeds_per_point`` runs), each short and each
open switch; ``healthy_runs`` healthy runs at random pressures; ``calibration_runs`` healthy
runs at random pressures that nothing is fitted on, which set the thresholds.

* The paper's part: nominal M and spread per pressure, the templates' M, G/V/chosen curves;
  a chosen curve's threshold is the largest calibration N times ``threshold_margin``.
* Ours: the healthy model (:mod:`~mapr_daemon.reasoner.diagnosis.healthy_model`) is fitted on all
healthy runs
  but the calibration ones, the fault subspace and signature models
  (:mod:`~mapr_daemon.reasoner.diagnosis.fault_models`) on the fault runs, and the anomaly
  threshold is
  set for ``false_alarm_rate`` (:mod:`~mapr_daemon.reasoner.diagnosis.false_alarm`) on the
  calibration
  runs' scores.

>>> # d = build(load_actuator(default_actuator_path()), DictionarySpec())
>>> # d.save("dictionary.npz")
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import (
    PARAMETRIC,
    Fault,
    FaultSet,
    at_severity,
    nominal_value,
    range_end,
)
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import (
    classifier,
    compound,
    curves,
    detection_map,
    false_alarm,
    fault_models,
    healthy_model,
    matched_filter,
)
from mapr_daemon.reasoner.diagnosis.dictionary import (
    Dictionary,
    DictionarySpec,
    PaperCurve,
    Template,
    pressure_weights,
)
from mapr_daemon.reasoner.diagnosis.false_alarm import calibrate as calibrate_rate
from mapr_daemon.reasoner.diagnosis.false_alarm import calibrate_gaussian
from mapr_daemon.reasoner.diagnosis.features import (
    EXTENDED_SIGNALS,
    SECTOR_SIGNALS,
    SWITCH_SIGNALS,
    WindowSpec,
    column_names,
    derived_signals,
    feature_matrix,
    reasoner_signals,
    record_starts,
)
from mapr_daemon.reasoner.training.corpus import (
    RUNS_PER_BATCH,
    BitRuns,
    Runs,
    bit_layout,
    stream_bit,
)

PAPER_THRESHOLD_SD = 3.0
"""A paper curve's threshold is at least this many healthy spreads of its cell."""
SD_FLOOR_COLUMN = 0.1
"""Floor of a cell's healthy spread: this share of its column's median spread over windows."""
SD_FLOOR_REL = 0.01
"""... and this share of the column's typical magnitude: quiet windows (a held position, a
spectrum of pure quantisation noise) have nearly zero spread, which would make any LSB flip
look like an anomaly."""
FAULT_CALIBRATION = "fault-calibration"
"""Role prefix of the fault calibration runs (``fault-calibration:<kind>@<severity>``)."""
DETECTION_MAP = "detection-map"
"""Role prefix of the detection map's runs (``detection-map:<kind>@<severity>``)."""
FAULT_CALIBRATION_FROM = 0.25
"""Their severities are uniform from this fraction of range to its end (the range the
benches score severity on)."""





def run_matrices(runs: Runs, starts: np.ndarray, length: int,
                 signals: tuple[str, ...] | None = None, *,
                 switch_temperatures: bool = False) -> FloatArray:
    """M ``(n, W, C)`` of every run (corner windows, then the record rows); ``signals`` by
    default :func:`~mapr_daemon.reasoner.diagnosis.features.reasoner_signals` of the runs'
    channels (with the switch temperatures' when ``switch_temperatures``)."""
    sig = derived_signals(runs.channels, runs.command_deg)
    names = (reasoner_signals(tuple(runs.channels), switch_temperatures) if signals is None
             else signals)
    return feature_matrix(sig, starts, length, runs.sample_rate_hz, names)


@dataclasses.dataclass(frozen=True)
class Plan:
    """Every run of a build batch: faults, dynamic pressure, seed, role, and the flight
    condition (``None``: the plant's own draw around the actuator file's values)."""

    faults: list[FaultSet]
    pressures_pa: list[float]
    seeds: list[int]
    roles: list[str]
    ambient_c: list[float | None]
    bus_v: list[float | None]


def _plan(params: ActuatorParams, spec: DictionarySpec) -> Plan:
    """Fault sets, pressures, seeds, roles and conditions of every run of the build batch.

    Roles: ``nominal@q``, ``<kind>@q@s`` (s the severity), ``short:<sw>@q``, ``open:<sw>@q``,
    ``healthy``, ``calibration`` and ``fault-calibration:<kind>@s`` (held out from every fit,
    :func:`calibrate_explanations`). With ``spec.envelope`` every run's ambient temperature and
    bus mean are drawn uniformly over the actuator's envelope (``envelope.ambient_*_c``,
    ``bus.min_v..max_v``), and a ``spec.ground_share`` of the healthy and calibration runs are
    BITs on the ground (0 Pa), the others at pressures uniform up to the envelope's maximum.
    """
    for k in spec.kinds:
        if k not in PARAMETRIC:
            raise ConfigError(f"not a parametric fault kind: {k}", field="kinds")
    if len(spec.pressures_pa) < 1 or spec.nominal_per_pressure < 2:
        raise ConfigError("need pressures and >= 2 nominal runs per pressure", field="spec")
    if spec.seeds_per_point < 1:
        raise ConfigError("need >= 1 run per point", field="seeds_per_point")
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
                for _ in range(spec.seeds_per_point):
                    add(FaultSet.of([at_severity(params, kind, s)]), q, f"{kind}@{q:g}@{s:g}")
        for sw in spec.shorts:
            add(FaultSet.of([Fault("short", switch=sw)]), q, f"short:{sw}@{q:g}")
        for sw in spec.opens:
            add(FaultSet.of([Fault("open", switch=sw)]), q, f"open:{sw}@{q:g}")
    rng = np.random.default_rng(spec.seed_base + 7919)
    lo, hi = spec.calibration_pressure_pa
    if spec.envelope:
        lo, hi = 0.0, params.envelope.max_dynamic_pressure_pa
    for n, role in ((spec.healthy_runs, "healthy"), (spec.calibration_runs, "calibration")):
        draws = rng.uniform(lo, hi, n)
        if spec.ground_share > 0:
            draws[rng.random(n) < spec.ground_share] = 0.0
        for q in draws:
            add(FaultSet(), float(q), role)
    amb: list[float | None] = [None] * len(fs)
    bus: list[float | None] = [None] * len(fs)
    if spec.envelope:
        env = np.random.default_rng(spec.seed_base + 104729)
        env_t = env.uniform(params.envelope.ambient_min_c, params.envelope.ambient_max_c, len(fs))
        env_v = env.uniform(params.bus.min_v, params.bus.max_v, len(fs))
        amb, bus = [float(t) for t in env_t], [float(v) for v in env_v]
    # drawn last, from a generator of their own, so the runs above are the same with or
    # without them
    fault_rng = np.random.default_rng(spec.seed_base + 15485863)
    for kind in spec.kinds:
        for _ in range(spec.fault_calibration_runs):
            s = float(fault_rng.uniform(FAULT_CALIBRATION_FROM, 1.0))
            q = 0.0 if fault_rng.random() < spec.ground_share else float(fault_rng.uniform(lo, hi))
            add(FaultSet.of([at_severity(params, kind, s)]), q, f"{FAULT_CALIBRATION}:{kind}@{s:g}")
            t = float(fault_rng.uniform(params.envelope.ambient_min_c,
                                        params.envelope.ambient_max_c))
            v = float(fault_rng.uniform(params.bus.min_v, params.bus.max_v))
            amb.append(t if spec.envelope else None)
            bus.append(v if spec.envelope else None)
    map_rng = np.random.default_rng(spec.seed_base + 32452843)
    env_hi = params.envelope.max_dynamic_pressure_pa
    bus_edges = detection_map.band_edges(params.bus.min_v, params.bus.max_v)
    amb_edges = detection_map.band_edges(params.envelope.ambient_min_c,
                                         params.envelope.ambient_max_c)
    for kind in spec.kinds:
        for i in range(len(bus_edges) - 1):
            for j in range(len(amb_edges) - 1):
                for _ in range(spec.detection_map_runs):
                    s = float(map_rng.uniform(FAULT_CALIBRATION_FROM, 1.0))
                    q = 0.0 if map_rng.random() < 0.25 else float(map_rng.uniform(0.0, env_hi))
                    add(FaultSet.of([at_severity(params, kind, s)]), q,
                        f"{DETECTION_MAP}:{kind}@{s:g}")
                    bus.append(float(map_rng.uniform(bus_edges[i], bus_edges[i + 1])))
                    amb.append(float(map_rng.uniform(amb_edges[j], amb_edges[j + 1])))
    return Plan(fs, qs, seeds, roles, amb, bus)


def windows(spec: DictionarySpec, corners: tuple[int, ...], n_samples: int) -> np.ndarray:
    """First sample of every row of M: the paper's corner windows, then the record rows."""
    win = WindowSpec(spec.window_samples)
    return np.concatenate([win.starts(corners, n_samples),
                           record_starts(n_samples, win.length, spec.record_skip_samples)])


def build(params: ActuatorParams, spec: DictionarySpec,
          progress: Callable[[float], None] | None = None, *,
          workers: int | None = None, runs_per_batch: int = RUNS_PER_BATCH) -> Dictionary:
    """Simulate, extract M, keep the nominal statistics and templates, fit, calibrate.

    The runs are flown in batches of ``runs_per_batch`` on ``workers`` threads (default: the
    usable cores) and each batch is reduced to its M in its worker, so only M (runs x rows x
    columns) is kept of every run; the dictionary is the same, bit for bit, whatever the two.
    """
    plan = _plan(params, spec)
    todo = BitRuns.of(plan.faults, plan.pressures_pa, plan.seeds, plan.ambient_c, plan.bus_v)
    m, q, starts = build_matrices(params, spec, todo, progress, workers=workers,
                                  runs_per_batch=runs_per_batch)
    return assemble(params, spec, m, q, plan.roles, starts, params.sensors.sample_rate_hz)


def build_matrices(params: ActuatorParams, spec: DictionarySpec, runs: BitRuns,
                   progress: Callable[[float], None] | None = None, *,
                   workers: int | None = None, runs_per_batch: int = RUNS_PER_BATCH,
                   ) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """M ``(n, W, C)`` of every run of ``runs`` at ``spec``'s windows, their pressures, and
    M's window starts (see :func:`stream_matrices`)."""
    corners, n_samples = bit_layout(params)
    starts = windows(spec, corners, n_samples)
    m = stream_matrices(params, runs, starts, spec.window_samples, progress=progress,
                        workers=workers, runs_per_batch=runs_per_batch,
                        switch_temperatures=spec.switch_temperatures)
    return m, runs.dynamic_pressure_pa.copy(), starts


def stream_matrices(params: ActuatorParams, runs: BitRuns, starts: np.ndarray, length: int,
                    signals: tuple[str, ...] | None = None,
                    progress: Callable[[float], None] | None = None, *,
                    workers: int | None = None,
                    runs_per_batch: int = RUNS_PER_BATCH,
                    switch_temperatures: bool = False) -> FloatArray:
    """M ``(n, W, C)`` of every run, as :func:`run_matrices` of :func:`simulate_bit` gives it,
    bit for bit, but flown and reduced batch by batch on ``workers`` threads: each batch's raw
    channels are dropped once its M is computed, so memory holds M and ``workers`` batches."""
    m: FloatArray | None = None

    def reduce(r: Runs) -> FloatArray:
        return run_matrices(r, starts, length, signals, switch_temperatures=switch_temperatures)

    for lo, part in stream_bit(params, runs, reduce,
                               runs_per_batch=runs_per_batch, workers=workers,
                               progress=progress):
        if m is None:
            m = np.empty((runs.n, *part.shape[1:]))
        m[lo:lo + part.shape[0]] = part
    assert m is not None   # BitRuns.of refuses zero runs
    return m


BAND_SIGMAS = 4.0
"""How far (in its flight-to-flight standard deviations) a healthy parameter may scatter."""


def healthy_band(params: ActuatorParams, kind: str) -> float:
    """The severity a healthy actuator may show with nothing measured to predict it.

    Friction scatters from flight to flight (log-normal, ``motor.friction_flight_sd``) and no
    channel measures it, so friction up to ``exp(4 sd)`` of nominal is healthy, not a fault.
    The temperature-driven scatter of Ron, ESR and capacitance is predicted by the healthy
    model from the measured temperature, so their band is 0.
    """
    if kind != "friction":
        return 0.0
    lo, hi = nominal_value(params, kind), range_end(params, kind)
    factor = math.exp(BAND_SIGMAS * params.motor.friction_flight_sd)
    return float(min(max((lo * factor - lo) / (hi - lo), 0.0), 1.0))





def conclusive_floor_v(params: ActuatorParams, spec: DictionarySpec) -> float:
    """The lowest aircraft-bus voltage at which a BIT is conclusive: with healthy runs over the
    whole bus band (``spec.envelope``) the healthy model knows the dropout regime, so a BIT is
    conclusive down to the band's lower limit (less the headroom); without, only above the
    dropout knee."""
    if spec.envelope:
        return params.bus.min_v - healthy_model.SUPPLY_HEADROOM_V
    return healthy_model.supply_floor_v(params)


def assemble(params: ActuatorParams, spec: DictionarySpec, m: FloatArray, q: FloatArray,
             roles: list[str], starts: np.ndarray, sample_rate_hz: float) -> Dictionary:
    """The dictionary from already computed matrices (split out so tests can reuse a batch)."""
    grid = np.asarray(spec.pressures_pa, dtype=np.float64)
    role = np.asarray(roles)
    rows = classifier.PAPER_COLUMNS
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
    paper_cells = (slice(None), slice(None), slice(0, rows), slice(0, rows))
    for kind in spec.kinds:
        vals = tuple(at_severity(params, kind, s).value for s in spec.severities)
        templates.append(Template(kind, kind, "", spec.severities, vals, PARAMETRIC[kind].unit))
        tpl_m.append(np.stack([np.stack([m[role == f"{kind}@{q:g}@{s:g}"].mean(axis=0)
                                         for s in spec.severities])
                               for q in spec.pressures_pa])[paper_cells])
    for kind, switches in (("short", spec.shorts), ("open", spec.opens)):
        for sw in switches:
            templates.append(Template(f"{kind}:{sw}", kind, sw, (1.0,), (1.0,), "on/off"))
            tpl_m.append(np.stack([m[role == f"{kind}:{sw}@{q:g}"]
                                   for q in spec.pressures_pa])[paper_cells])
    switch = SWITCH_SIGNALS if spec.switch_temperatures else ()
    signals: tuple[str, ...] = (
        (*EXTENDED_SIGNALS, *switch)
        if m.shape[2] == len(column_names((*EXTENDED_SIGNALS, *switch)))
        else (*EXTENDED_SIGNALS, *SECTOR_SIGNALS, *switch))
    columns = tuple(column_names(signals))
    if len(columns) != m.shape[2]:
        raise ConfigError(f"M has {m.shape[2]} columns, no known signal set has",
                          field="signals")
    d = Dictionary(actuator=params.name, sample_rate_hz=sample_rate_hz,
                   window_samples=spec.window_samples, window_starts=starts,
                   signals=signals, columns=columns,
                   pressures_pa=grid, nominal_mean=nom, nominal_sd=sd, templates=templates,
                   template_m=tpl_m, paper={})
    d.paper = paper_curves(d)
    fit_ours(d, params, spec, m, q, roles)
    calib = role == "calibration"
    calibrate_paper(d, m[calib], q[calib], spec.threshold_margin)
    return d


def fit_ours(d: Dictionary, params: ActuatorParams, spec: DictionarySpec, m: FloatArray,
             q: FloatArray, roles: list[str]) -> None:
    """Our healthy model, fault subspace, signature models and threshold."""
    conds = [healthy_model.conditions(m[i], d.columns, float(q[i])) for i in range(m.shape[0])]
    floor = conclusive_floor_v(params, spec)
    valid = np.array([c.supply_min_v >= floor for c in conds])
    role = np.asarray(roles)
    fit_rows = np.flatnonzero(valid & ((role == "healthy") | np.char.startswith(role, "nominal@")))
    cells = healthy_model.record_cells(d.columns, m.shape[1], spec.record_pool)
    nominal_v = params.bus.nominal_v
    model, whiten = healthy_model.fit(m[fit_rows], [conds[i] for i in fit_rows], cells, nominal_v,
                                      floor, healthy_model.supply_floor_v(params),
                                      params.smps.output_voltage_v, spec.shrinkage_floor)
    fault_rows = np.flatnonzero(valid & ~np.isin(role, ["healthy", "calibration"])
                                & ~np.char.startswith(role, "nominal@")
                                & ~np.char.startswith(role, f"{FAULT_CALIBRATION}:")
                                & ~np.char.startswith(role, f"{DETECTION_MAP}:"))
    sig = np.stack([model.standardized(m[i], conds[i]) for i in fault_rows]) @ whiten
    model = healthy_model.with_subspace(model, sig, spec.subspace_dims)
    # the matched filter learns the fault's small-severity signature; a spec without such runs
    # of that kind builds a dictionary without it (the two other statistics share the rate)
    weak = [int(i) for i in fault_rows if roles[i].startswith(f"{matched_filter.KIND}@")
            and 0.0 < float(roles[i].rsplit("@", 1)[1]) <= matched_filter.MAX_SEVERITY]
    if weak:
        z_fit = np.stack([model.standardized(m[i], conds[i]) for i in fit_rows])
        z_weak = np.stack([model.standardized(m[i], conds[i]) for i in weak])
        sev_weak = np.array([float(roles[i].rsplit("@", 1)[1]) for i in weak])
        model = dataclasses.replace(model, matched=matched_filter.fit(z_fit, z_weak, sev_weak))
    y = {int(i): model.coordinates(m[i], conds[i]) for i in fault_rows}
    knots = np.asarray(spec.knots, dtype=np.float64)
    coef: list[FloatArray | None] = []
    sev_coef: list[FloatArray | None] = []
    grids: list[FloatArray | None] = []
    k_dims = model.projection.shape[1]
    points: list[FloatArray | None] = []
    for t in d.templates:
        if t.switch:
            coef.append(None)
            sev_coef.append(None)
            grids.append(None)
            points.append(np.stack([
                np.mean([y[int(i)] for i in np.flatnonzero(role == f"{t.name}@{p:g}")
                         if int(i) in y] or [np.zeros(k_dims)], axis=0)
                for p in spec.pressures_pa]))
            continue
        rows = [int(i) for i in fault_rows if roles[i].startswith(f"{t.kind}@")]
        sev = np.array([float(roles[i].rsplit("@", 1)[1]) for i in rows])
        ys = np.stack([y[i] for i in rows])
        coef.append(fault_models.fit_parametric(ys, sev, [conds[i] for i in rows], knots,
                                                nominal_v))
        sev_coef.append(fault_models.fit_severity(ys, sev, [conds[i] for i in rows], nominal_v,
                                                  params.smps.output_voltage_v))
        grids.append(np.stack([np.stack([
            np.mean([y[int(i)] for i in np.flatnonzero(role == f"{t.kind}@{p:g}@{sv:g}")
                     if int(i) in y] or [np.zeros(k_dims)], axis=0)
            for sv in spec.severities]) for p in spec.pressures_pa]))
        points.append(None)
    d.healthy = model
    d.models = fault_models.FaultModels(knots, coef, points, d.pressures_pa, nominal_v,
                                        [healthy_band(params, t.kind) for t in d.templates],
                                        grids, np.asarray(spec.severities, dtype=np.float64),
                                        sev_coef, params.smps.output_voltage_v)
    calib = np.flatnonzero(valid & (role == "calibration"))
    both = np.array([classifier.score_of(d, m[i], float(q[i])) for i in calib])
    scores = both[:, 0]
    filtered = [classifier.matched_score(d, m[i], float(q[i])) for i in calib]
    # the rate is shared by the statistics (any one raises the alarm)
    share = spec.false_alarm_rate / (2 if model.matched is None else 3)
    cal = calibrate_rate(scores, share)
    cal_null = calibrate_rate(both[:, 1], share)
    d.threshold = cal.threshold
    d.score_spread = float(max(scores.std(), 1e-6))
    d.log_score_spread = float(max(np.log(np.maximum(scores, 1e-9)).std(), 0.05))
    d.calibration = {"runs": float(cal.runs), "score_max": cal.score_max,
                     "score_median": cal.score_median, "false_alarm_rate": spec.false_alarm_rate,
                     "null_threshold": cal_null.threshold, "null_max": cal_null.score_max,
                     "null_chi2_dof": cal_null.dof,
                     "null_expected_above_max": cal_null.expected_above_max,
                     "null_tail_governs": float(cal_null.tail_governs),
                     "tail_governs": float(cal.tail_governs),
                     "chi2_scale": cal.scale, "chi2_dof": cal.dof,
                     "expected_above_max": cal.expected_above_max,
                     "shrinkage": model.shrinkage, "subspace_dims":
                     float(model.projection.shape[1]), "healthy_fit_runs": float(fit_rows.size),
                     "inconclusive_runs": float((~valid).sum()),
                     **false_alarm.quantile_entries("score", scores),
                     **false_alarm.quantile_entries("null", both[:, 1])}
    calibrate_explanations(d, m, q, np.flatnonzero(
        valid & np.char.startswith(role, f"{FAULT_CALIBRATION}:")))
    if model.matched is not None:
        raw = np.array(filtered, dtype=np.float64)  # raw output (mean 0, sd 1 not yet set)
        mean, sd = float(raw.mean()), float(max(raw.std(ddof=1), 1e-12))
        cal_m = calibrate_gaussian((raw - mean) / sd, share)
        d.calibration.update({"matched_threshold": cal_m.threshold, "matched_mean": mean,
                              "matched_sd": sd, "matched_max": cal_m.score_max,
                              "matched_tail_governs": float(cal_m.tail_governs),
                              **false_alarm.quantile_entries("matched", (raw - mean) / sd)})
    measure_detection(d, params, m, q, roles, conds)


def measure_detection(d: Dictionary, params: ActuatorParams, m: FloatArray, q: FloatArray,
                      roles: list[str], conds: list[healthy_model.Conditions]) -> None:
    """The detection map from its runs, decided with the finished dictionary and binned by
    the conditions read from their own records (as a decision reads them); inconclusive runs
    are left out."""
    runs = []
    for i in range(len(roles)):
        if not roles[i].startswith(f"{DETECTION_MAP}:"):
            continue
        dec = classifier.decide(d, m[i], float(q[i]))
        if dec.inconclusive:   # below the supply floor a BIT judges nothing: not a miss
            continue
        runs.append((roles[i].split(":", 1)[1].split("@", 1)[0], conds[i].supply_v,
                     conds[i].temperature_c, dec.anomaly))
    if runs:
        d.detection = detection_map.DetectionMap.measure(
            tuple(detection_map.band_edges(params.bus.min_v, params.bus.max_v)),
            tuple(detection_map.band_edges(params.envelope.ambient_min_c,
                                           params.envelope.ambient_max_c)), runs)


def calibrate_explanations(d: Dictionary, m: FloatArray, q: FloatArray,
                           rows: npt.NDArray[np.int64]) -> None:
    """The pair and unexplained thresholds (:mod:`~mapr_daemon.reasoner.diagnosis.compound`)
    from the fault calibration runs ``rows``; none without such runs (the dictionary then
    names no pairs and says unexplained only where no fault beats health)."""
    if rows.size == 0:
        return
    stats = np.array([classifier.explanation_statistics(d, m[i], float(q[i])) for i in rows])
    measured = stats[np.isfinite(stats[:, 0])]   # runs a switch template fits best: not held
    if measured.shape[0] == 0:
        return
    d.calibration.update({
        "fault_calibration_runs": float(measured.shape[0]),
        "pair_gain_max": float(measured[:, 0].max()),
        "pair_threshold": max(compound.PAIR_MARGIN * float(measured[:, 0].max()),
                              compound.PAIR_FLOOR),
        "unexplained_max": float(measured[:, 1].max()),
        "unexplained_threshold": compound.MARGIN * float(measured[:, 1].max())})


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
        nom = d.nominal_mean[:, :cols, :cols]
        n_all = curves.distance(tm[:, :, :cols, :cols], nom[:, None])  # (K, S, 32, 32)
        n_all = np.concatenate([np.zeros_like(n_all[:, :1]), n_all], axis=1)
        k = reference_pressure
        g = curves.good_times(n_all[k, 1:])
        v = curves.final_values(n_all[k, 1:], g)
        if v.shape[0] == 0:
            continue
        c = curves.chosen_curve(v, scale=d.nominal_sd[:cols, :cols])
        out[t.kind] = PaperCurve(t.kind, g, v, c.row, c.col, c.reference,
                                 n_all[:, :, c.row, c.col], math.inf)
    return out


def calibrate_paper(d: Dictionary, m: FloatArray, q: FloatArray, margin: float) -> None:
    """The paper classifier's thresholds from healthy runs (per-curve N)."""
    if m.shape[0] < 2:
        raise ConfigError("need >= 2 calibration runs", field="calibration_runs")
    for c in d.paper.values():
        w = np.stack([np.tensordot(pressure_weights(d.pressures_pa, float(qi)),
                                   d.nominal_mean, axes=1) for qi in q])
        n = np.abs(m[:, c.row, c.col] - w[:, c.row, c.col])
        floor = PAPER_THRESHOLD_SD * float(d.nominal_sd[c.row, c.col])
        object.__setattr__(c, "threshold", float(max(n.max() * margin, floor)))
