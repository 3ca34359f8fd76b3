"""One flight's parameters from the traffic between BITs: the EKF over the qualifying segments.

:class:`FlightTracker` takes one actuator's bus-rate channels of a flight (outside its BITs),
selects the windows with enough excitation (:mod:`.segments`) and runs the EKF of
:mod:`~mapr_daemon.reasoner.ekf` over them, starting from the unit's baseline (a
:class:`~mapr_daemon.reasoner.ekf.estimator.Reference`: commissioned, or the data sheet's).
Each parameter is read from the segments that qualified for it (:data:`PASSES`). The
flight ends with one :class:`FlightEstimate`: per trended parameter a value, a standard
deviation and the change from the baseline.

Why the EKF and not a UKF or particle filter: the model is linear in the parameters given the
measured currents and position (friction enters the speed recursion linearly, resistances the
power balance, the taps their normal equations), so the EKF's linearisation error is the speed
recursion's, small over a 10 ms block; a UKF would cost 2n+1 = 17 propagations per block for
no gain, and the parameter posteriors are near Gaussian (no multimodality for a particle
filter to carry). What the EKF gets wrong is its *stated* sd when the model is wrong, so:

**The stated sd.** The qualifying segments are split into :data:`GROUPS` contiguous groups,
each filtered by a fresh EKF from the baseline (the same cost as one pass). The flight's value
is the groups' inverse-variance-weighted mean; its sd is the larger of the EKF's own
(combined) sd and the groups' robust scatter (``sum w_g^2 (x_g - x)^2 * G/(G-1)``) scaled by
Student's t with ``G-1`` degrees of freedom to the 90 % band. Model error that differs between
parts of a flight then widens the band; the EKF's sd alone covers only sensor noise.

Trended parameters (:data:`TRENDED`):

* ``friction`` — the friction factor relative to the baseline: viscous and Coulomb friction
  each as a ratio to the baseline's, combined by generalised least squares with their 2x2
  covariance (the friction fault scales both alike, :mod:`mapr_daemon.ema.faults`);
* ``loop_r`` — the loop resistance (``r_other``, ohm; change in ohm);
* ``phase_a_ron`` — the phase-A high-side Ron change (ohm): the change of ``r_a_high -
  r_other`` divided by the mean duty in phase A's driven sectors (complementary PWM: the high
  side conducts for the duty ``d``, so its Ron enters the loop as ``d*Ron``), the duty read
  from ``inverter_duty`` when the bus carries it, else from the voltage balance;
* ``bus0`` — the DC-bus response proxy's first tap (V/A); the capacitor's ESR moves it. The
  capacitance is not resolved at the bus rate (:mod:`~mapr_daemon.reasoner.ekf.model`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import stats

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import RecordError
from mapr_daemon.reasoner.ekf import model as em
from mapr_daemon.reasoner.ekf.estimator import DRIFT_SD, Estimate, ParameterEstimator, Reference
from mapr_daemon.reasoner.inflight.segments import (
    CRITERION,
    Criterion,
    Excitation,
    Segment,
    excitation,
    select,
)
from mapr_daemon.reasoner.inflight.segments import (
    GROUPS as QUALIFY_GROUPS,
)

TRENDED: tuple[str, ...] = ("friction", "loop_r", "phase_a_ron", "bus0")
"""The per-flight parameters, in report order."""
UNITS: dict[str, str] = {"friction": "x baseline", "loop_r": "ohm", "phase_a_ron": "ohm",
                         "bus0": "V/A (proxy)"}
PASSES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "friction": (("friction",), ("friction",)),
    "resistance": (("loop", "phase_a"), ("loop_r", "phase_a_ron")),
    "bus": (("bus",), ("bus0",)),
}
"""Filter passes: each runs over the segments that qualified for its groups and reports its
trended parameters. A segment that informs only the bus taps (a DC-link current step at low
speed) must not move friction, whose model is wrong there; so each parameter is read from
its own segments (the cost is the sum of the passes' filtered time)."""
PASS_PARAMETERS: dict[str, tuple[str, ...]] = {
    "friction": ("viscous", "coulomb"), "resistance": ("r_other", "r_a_high"),
    "bus": ("bus0", "bus1")}
"""The EKF parameters each pass informs (what commissioning takes from it)."""
GROUPS = 4
"""Independent filter runs per flight (the scatter that widens the stated sd)."""
BAND = 0.90
"""The stated band the sd is scaled for."""
IN_FLIGHT_DRIFT: dict[str, float] = {k: v * (0.1 if k in em.PARAMETERS else 1.0)
                                     for k, v in DRIFT_SD.items()}
"""Process noise per block in flight: parameters drift a tenth of the BIT filter's (within a
flight they are nearly constant; the winding warms a few kelvin)."""


@dataclasses.dataclass(frozen=True)
class Tracked:
    """One trended parameter of one flight."""

    value: float
    """The flight's value (friction: factor over the baseline; others in their unit)."""
    sd: float
    change: float
    """``value`` minus the baseline's (friction: ``value - 1``)."""
    ekf_sd: float
    """The EKF's own sd, before the groups' scatter was taken into account."""


@dataclasses.dataclass(frozen=True)
class FlightEstimate:
    """A flight's in-flight estimate: the trended parameters and how much data they rest on."""

    parameters: dict[str, Tracked]
    flight_s: float
    filtered_s: float
    qualified_s: dict[str, float]
    """Seconds of windows that qualified for each group (:data:`.segments.GROUPS`)."""
    cpu_s: float
    """Thread CPU time the tracker took for this flight."""

    @property
    def real_time_factor(self) -> float:
        return self.flight_s / max(self.cpu_s, 1e-9)

    def as_event(self) -> dict[str, dict[str, float | str]]:
        """JSON-ready: per parameter value, sd, change and unit."""
        return {k: {"value": float(f"{t.value:.6g}"), "sd": float(f"{t.sd:.3g}"),
                    "change": float(f"{t.change:.4g}"), "unit": UNITS[k]}
                for k, t in self.parameters.items()}


def _duty(channels: Mapping[str, FloatArray], plant: em.Plant) -> tuple[FloatArray, FloatArray]:
    """Per sample: ``i^2`` weight of phase A's driven sectors and the duty there."""
    i = np.stack([np.asarray(channels[k], dtype=np.float64) for k in
                  ("phase_a_current_a", "phase_b_current_a", "phase_c_current_a")])
    line = np.add.reduce(np.abs(i), axis=0) / 2.0
    weight = np.where((i[0] > 0.5 * line) & (line > 0.2), line * line, 0.0)
    if "inverter_duty" in channels:
        duty = np.abs(np.asarray(channels["inverter_duty"], dtype=np.float64))
    else:  # six-step: the line voltage is 2*K*omega + R*i, the duty its share of the DC link
        theta = np.radians(np.asarray(channels["position_deg"], dtype=np.float64)) * plant.ratio
        omega = np.gradient(theta, plant.dt)
        v = np.maximum(np.asarray(channels["dc_bus_voltage_v"], dtype=np.float64), 1.0)
        duty = np.clip((2.0 * plant.k_e * np.abs(omega) + plant.r_loop_nom * line) / v, 0.0, 1.0)
    return weight, duty


@dataclasses.dataclass(frozen=True)
class _Group:
    est: Estimate
    cov: FloatArray
    duty: float


class FlightTracker:
    """One actuator's in-flight tracker; :meth:`track` once per flight."""

    def __init__(self, params: ActuatorParams, baseline: Reference | None = None,
                 criterion: Criterion = CRITERION, groups: int = GROUPS) -> None:
        self.params = params
        self.plant = em.Plant.of(params)
        self.baseline = baseline if baseline is not None else Reference.nominal(params)
        self.criterion = criterion
        self.groups = max(1, int(groups))

    def excitation(self, channels: Mapping[str, FloatArray]) -> Excitation:
        """The flight's per-window information (:func:`.segments.excitation`)."""
        return excitation(self.plant, channels, self.criterion)

    def track(self, channels: Mapping[str, FloatArray],
              dynamic_pressure_pa: float | FloatArray) -> FlightEstimate:
        """The flight's estimate; raises :class:`RecordError` when nothing qualified.

        A parameter none of whose windows qualified is left out of the estimate.
        """
        t0 = time.thread_time()
        n = np.asarray(channels["position_deg"]).size
        q = np.broadcast_to(np.asarray(dynamic_pressure_pa, dtype=np.float64), (n,))
        out = self.track_excitation(channels, q, self.excitation(channels), n * self.plant.dt)
        return dataclasses.replace(out, cpu_s=time.thread_time() - t0)

    def track_excitation(self, channels: Mapping[str, FloatArray], q: FloatArray,
                         exc: Excitation, flight_s: float) -> FlightEstimate:
        """The estimate from windows already assessed (``exc`` indexes ``channels``; a
        stream's kept windows, :class:`~mapr_daemon.reasoner.inflight.accumulate.
        FlightAccumulator`); ``flight_s`` is the flight's bus time."""
        t0 = time.thread_time()
        per = exc.qualifies(self.criterion).sum(axis=0) * exc.window * self.plant.dt
        weight, duty = _duty(channels, self.plant)
        out: dict[str, Tracked] = {}
        filtered = 0
        for groups, names in PASSES.values():
            segs = select(exc, self.criterion, groups)
            if not segs:
                continue
            filtered += sum(s.n_samples for s in segs)
            runs = [self._run(part, channels, q, weight, duty)
                    for part in _split(segs, self.groups)]
            out.update({k: v for k, v in self._combine(runs).items() if k in names})
        if not out:
            raise RecordError("no segment of the flight had enough excitation",
                              field="inflight")
        return FlightEstimate(out, flight_s=flight_s, filtered_s=filtered * self.plant.dt,
                              qualified_s=dict(zip(QUALIFY_GROUPS, map(float, per), strict=True)),
                              cpu_s=time.thread_time() - t0)

    def _run(self, segs: Sequence[Segment], channels: Mapping[str, FloatArray], q: FloatArray,
             weight: FloatArray, duty: FloatArray) -> _Group:
        est = ParameterEstimator(self.params, self.baseline, drift_sd=IN_FLIGHT_DRIFT)
        w_sum = 0.0
        wd_sum = 0.0
        for s in segs:
            part = {k: np.asarray(channels[k])[s.start:s.stop] for k in em.NEEDED}
            est.run(part, float(np.mean(q[s.start:s.stop])))
            w_sum += float(weight[s.start:s.stop].sum())
            wd_sum += float((weight * duty)[s.start:s.stop].sum())
        return _Group(est.estimate(), est.covariance[2:, 2:],
                      wd_sum / w_sum if w_sum > 0.0 else math.nan)

    def _combine(self, groups: Sequence[_Group]) -> dict[str, Tracked]:
        base = self.baseline.value
        idx = {k: j for j, k in enumerate(em.PARAMETERS)}
        per: dict[str, list[tuple[float, float]]] = {k: [] for k in TRENDED}
        for g in groups:
            x = np.array([g.est.value[k] for k in em.PARAMETERS])
            c = g.cov
            # friction: both ratios to the baseline estimate one factor (GLS)
            fi = [idx["viscous"], idx["coulomb"]]
            ref = np.array([base["viscous"], base["coulomb"]])
            r = x[fi] / ref
            cf = c[np.ix_(fi, fi)] / np.outer(ref, ref)
            inv = np.linalg.pinv(cf)
            den = float(inv.sum())
            per["friction"].append((float(inv.sum(axis=0) @ r) / den, 1.0 / den))
            o, a = idx["r_other"], idx["r_a_high"]
            per["loop_r"].append((float(x[o]), float(c[o, o])))
            d = g.duty  # the fault's share of the contrast is this flight's duty
            if d == d and d > 0.0:
                contrast = (x[a] - x[o]) - (base["r_a_high"] - base["r_other"])
                var = float(c[a, a] + c[o, o] - 2.0 * c[a, o])
                per["phase_a_ron"].append((contrast / d, var / (d * d)))
            b = idx["bus0"]
            per["bus0"].append((float(x[b]), float(c[b, b])))
        out: dict[str, Tracked] = {}
        for k, vals in per.items():
            if not vals:
                continue
            v, var = np.array(vals).T
            value, sd, ekf_sd = _pool(v, var)
            ref_val = {"friction": 1.0, "loop_r": base["r_other"], "phase_a_ron": 0.0,
                       "bus0": base["bus0"]}[k]
            out[k] = Tracked(value=value, sd=sd, change=value - ref_val, ekf_sd=ekf_sd)
        return out


def _pool(v: FloatArray, var: FloatArray) -> tuple[float, float, float]:
    """Inverse-variance mean, stated sd (EKF's or the groups' t-scaled scatter), EKF sd."""
    w = 1.0 / np.maximum(var, 1e-300)
    w = w / w.sum()
    mean = float(w @ v)
    ekf_sd = math.sqrt(float(1.0 / np.sum(1.0 / np.maximum(var, 1e-300))))
    g = v.size
    if g < 2:
        return mean, ekf_sd, ekf_sd
    robust = math.sqrt(float(np.sum(w * w * (v - mean) ** 2)) * g / (g - 1))
    z = float(stats.norm.ppf(0.5 + BAND / 2.0))
    t = float(stats.t.ppf(0.5 + BAND / 2.0, g - 1))
    return mean, max(ekf_sd, robust * t / z), ekf_sd


def _split(segs: Sequence[Segment], groups: int) -> list[list[Segment]]:
    """Contiguous groups of segments with about equal filtered time (none empty)."""
    if len(segs) <= groups:
        return [[s] for s in segs]
    lengths = np.cumsum([s.n_samples for s in segs])
    cut = np.searchsorted(lengths, lengths[-1] * np.arange(1, groups) / groups, side="right")
    bounds = [0, *sorted(set(int(c) for c in cut if 0 < c < len(segs))), len(segs)]
    return [list(segs[a:b]) for a, b in itertools.pairwise(bounds) if b > a]


def commissioning_values(tracker: FlightTracker, channels: Mapping[str, FloatArray],
                         dynamic_pressure_pa: float | FloatArray) -> dict[str, float]:
    """One healthy flight's EKF parameters, each from its own pass (:data:`PASSES`), filtered
    from the tracker's current baseline; parameters no segment informed are left out."""
    n = np.asarray(channels["position_deg"]).size
    q = np.broadcast_to(np.asarray(dynamic_pressure_pa, dtype=np.float64), (n,))
    exc = tracker.excitation(channels)
    weight, duty = _duty(channels, tracker.plant)
    out: dict[str, float] = {}
    for pass_name, (groups, _) in PASSES.items():
        segs = select(exc, tracker.criterion, groups)
        if segs:
            g = tracker._run(segs, channels, q, weight, duty)
            out.update({k: g.est.value[k] for k in PASS_PARAMETERS[pass_name]})
    return out


def adopt(tracker: FlightTracker, values: Sequence[Mapping[str, float]]) -> Reference:
    """Move the tracker's baseline to the mean of healthy flights' values (a parameter no
    flight informed keeps its value); returns the new baseline."""
    keys = {k for v in values for k in v}
    if not keys:
        raise RecordError("no commissioning flight had enough excitation", field="inflight")
    ref = dataclasses.replace(tracker.baseline, value=dict(tracker.baseline.value),
                              history=list(tracker.baseline.history))
    ref.adapt({k: float(np.mean([v[k] for v in values if k in v])) for k in sorted(keys)})
    tracker.baseline = ref
    return ref


def commission(tracker: FlightTracker, flights: Sequence[tuple[Mapping[str, FloatArray],
                                                                float | FloatArray]]) -> Reference:
    """The unit's in-flight baseline: the mean EKF parameters over healthy flights
    (:func:`commissioning_values` of each, then :func:`adopt`)."""
    return adopt(tracker, [commissioning_values(tracker, c, q) for c, q in flights])
