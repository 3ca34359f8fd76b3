"""RUL from the trend across flights, fitted with the aging shape of the component.

Each aging kind follows a published degradation shape (:mod:`mapr_daemon.ema.degradation`), so
its degradation fraction ``h`` (0 healthy, 1 at the failure threshold) is fitted with that
shape's family rather than a generic polynomial:

* ``exponential`` — ``h = A*(exp(b*n) - 1)``: power-MOSFET Ron under thermal-overstress aging
  (Celaya, Saxena, Saha, Goebel, "Prognostics of power MOSFETs under thermal stress
  accelerated aging using data-driven and model-based methodologies", PHM Society 2011: an
  exponential model of the Ron rise tracked by an EKF and a particle filter) and electrolytic
  capacitance loss (Celaya, Kulkarni, Biswas, Goebel, "Towards a model-based prognostics
  methodology for electrolytic capacitors: a case study based on electrical overstress
  accelerated aging", Int. J. of PHM 2012: an empirical exponential degradation model in a
  Kalman filter);
* ``reciprocal`` — ``h = A*(1/(1 - k*n) - 1)``: ESR of an electrolytic capacitor losing
  electrolyte, ``1/ESR`` falling linearly with time (the empirical form the aging model uses).
  Here ``A`` is not free: ``ESR(n)/ESR0 = 1/(1 - k*n)`` and the threshold is a ratio ``T`` of
  ESR0, so ``A = 1/(T - 1)`` (:data:`FIXED_AMPLITUDE`) and ``k`` alone is fitted;
* ``power`` — ``h = A*n**p``: wear of bearings and gears (the aging model's ``n**1.5``; ``p`` is
  fitted, not assumed).

Each family has one nonlinear parameter (``b``, ``k``, ``p``) and a linear amplitude ``A``.
The fit is Bayesian on a grid of the nonlinear parameter, flat in its logarithm and wide
enough to know nothing of the unit's life, or weighted by a fleet prior
(:class:`ShapePrior`). Given it, ``A`` is linear-Gaussian (weighted least squares with the
per-BIT estimate's *measured* noise, :class:`Noise`), and the grid's marginal likelihoods
weight it. Draws of ``(parameter, A)`` give the flight where ``h`` crosses 1 in closed form;
their 5/50/95 % points are the RUL and its bounds. An estimate in the estimator's dead
zone (:attr:`Noise.floor`) is censored: it weights the draws by the chance of reading the
floor, measured as a function of the degradation (importance resampling), instead of being
fitted as a value. A draw that
never crosses (``A <= 0``, or beyond ``horizon`` flights) counts as ``inf``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt
from scipy.special import ndtr

from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.features import FloatArray
from mapr_daemon.reasoner.prognosis import RulEstimate, quantiles

SHAPES: dict[str, str] = {
    "capacitance": "exponential", "smps_ron_high": "exponential",
    "smps_ron_low": "exponential", "inverter_ron_a_high": "exponential",
    "esr": "reciprocal", "friction": "power",
}
"""The shape family each aging kind is fitted with."""

FLOOR_TOLERANCE = 1e-6
"""Estimates within this of the lowest calibration estimate count as at the floor."""
FIXED_AMPLITUDE: dict[str, float] = {"esr": 1.0 / (FAILURE["esr"] - 1.0)}
"""Kinds whose amplitude the physics fixes (the rest fit ``A``)."""

_GRIDS: dict[str, FloatArray] = {
    "exponential": np.logspace(-4.0, -1.0, 241),   # b, 1/flight: e-folding 10..10,000 flights
    "reciprocal": np.logspace(-5.0, -1.5, 241),    # k, 1/flight: 1/k = 30..100,000 flights
    "power": np.linspace(0.5, 4.0, 141),           # p
}


def basis(shape: str, theta: FloatArray, n: FloatArray) -> FloatArray:
    """``g_theta(n)`` of the family, ``(grid, flights)``; ``h = A*g``. ``inf`` where the
    reciprocal form has already diverged (the part failed before ``n``)."""
    t = np.asarray(theta, dtype=np.float64)[:, None]
    x = np.asarray(n, dtype=np.float64)[None, :]
    if shape == "exponential":
        out: FloatArray = np.expm1(np.minimum(t * x, 300.0))  # squares stay finite
    elif shape == "reciprocal":
        kn = t * x
        with np.errstate(divide="ignore"):
            out = np.where(kn < 1.0, kn / np.maximum(1.0 - kn, 1e-300), np.inf)
    elif shape == "power":
        out = np.power(np.maximum(x, 0.0), t)
    else:
        raise ConfigError(f"unknown trend shape {shape!r}", field="shape")
    return out


def crossing(shape: str, theta: FloatArray, amp: FloatArray) -> FloatArray:
    """The flight where ``A*g_theta(n) = 1`` (``inf`` when ``A <= 0``: no degradation)."""
    a = np.asarray(amp, dtype=np.float64)
    pos = a > 0.0
    safe = np.where(pos, a, 1.0)
    if shape == "exponential":
        n = np.log1p(1.0 / safe) / theta
    elif shape == "reciprocal":
        n = 1.0 / (theta * (safe + 1.0))
    elif shape == "power":
        n = safe ** (-1.0 / theta)
    else:
        raise ConfigError(f"unknown trend shape {shape!r}", field="shape")
    out: FloatArray = np.where(pos, n, np.inf)
    return out


def _transition(h: FloatArray, at_floor: npt.NDArray[np.bool_]) -> tuple[float, float]:
    """Where (and how sharply) the estimate leaves its floor as the degradation grows: the
    degradation where the share of floored estimates, per calibration level, crosses one
    half (interpolated), and as its sd a quarter of the span from the last all-floored to the
    first never-floored level (the span taken as +/- 2 sd), at least 0.02."""
    levels = np.unique(h)
    share = np.array([at_floor[h == v].mean() for v in levels])
    below = np.nonzero(share >= 0.5)[0]
    if below.size == 0:
        return float(levels[0]), 0.02
    i = int(below.max())
    if i + 1 >= levels.size:
        mid = float(levels[-1])
    else:
        f0, f1 = share[i], share[i + 1]
        mid = float(levels[i] + (f0 - 0.5) / max(f0 - f1, 1e-9) * (levels[i + 1] - levels[i]))
    full = levels[share >= 1.0]
    none = levels[share <= 0.0]
    lo = float(full.max()) if full.size else float(levels[0])
    hi = float(none[none > lo].min()) if (none > lo).any() else float(levels[-1])
    return mid, max(0.25 * (hi - lo), 0.02)


@dataclasses.dataclass(frozen=True)
class Noise:
    """The per-BIT degradation estimate as measured against known degradations.

    ``estimate = offset + gain*h + e`` with ``sd(e) = sd0 + sd1*h``: measured on BITs flown at
    known degradation (:meth:`measure`), so the trend is fitted on the estimate's own scale
    error and scatter, not on an assumed one. ``floor``: the estimator's dead zone — a value it
    reports for every degradation too small to tell from healthy scatter (the classifier's
    healthy band). An estimate at the floor says only "at most this much" and is treated as
    censored, not as a measurement of zero.
    """

    sd0: float
    sd1: float = 0.0
    offset: float = 0.0
    gain: float = 1.0
    floor: float | None = None
    detection: float = 0.0
    """Degradation at which half the estimates leave the floor (measured)."""
    detection_sd: float = 0.02
    """Width of that transition (measured; at least 0.02)."""

    @classmethod
    def measure(cls, h_true: FloatArray, h_est: FloatArray) -> Noise:
        """Linear calibration of the estimate on the truth (above its floor), its scatter."""
        x = np.asarray(h_true, dtype=np.float64)
        y = np.asarray(h_est, dtype=np.float64)
        low = float(y.min())
        at_floor = y <= low + FLOOR_TOLERANCE
        floor = low if at_floor.sum() >= 2 else None
        detection, detection_sd = 0.0, 0.02
        if floor is not None:
            detection, detection_sd = _transition(x, at_floor)
            x, y = x[~at_floor], y[~at_floor]
        if x.size < 4 or np.ptp(x) <= 0.0:
            raise ConfigError("need at least four estimates above the floor at two or more "
                              "degradations", field="noise")
        gain, offset = np.polyfit(x, y, 1)
        if gain <= 0.05:
            raise ConfigError(f"the estimate does not follow the degradation (gain {gain:.3g})",
                              field="noise")
        resid = np.abs(y - (offset + gain * x)) * math.sqrt(math.pi / 2.0)  # E|e| -> sd
        s1, s0 = np.polyfit(x, resid, 1)
        if s0 <= 0.0 or s1 < 0.0:  # keep the growth non-negative and the floor positive
            s1 = max(s1, 0.0)
            s0 = max(float(np.mean(resid - s1 * x)), 1e-3)
        return cls(float(s0), float(s1), float(offset), float(gain), floor, detection,
                   detection_sd)

    def sd(self, h: FloatArray) -> FloatArray:
        out: FloatArray = self.sd0 + self.sd1 * np.clip(h, 0.0, 1.5)
        return out

    def censored(self, h_est: FloatArray) -> npt.NDArray[np.bool_]:
        """Which estimates sit at the floor."""
        y = np.asarray(h_est, dtype=np.float64)
        if self.floor is None:
            return np.zeros(y.shape, dtype=bool)
        out: npt.NDArray[np.bool_] = y <= self.floor + FLOOR_TOLERANCE
        return out


@dataclasses.dataclass(frozen=True)
class ShapePrior:
    """Fleet knowledge of a kind's shape parameter: ``log(theta) ~ N(mean, sd)``.

    Learned from run-to-failure units of the same kind (:meth:`learn`), as model-based
    prognostics does with accelerated-aging data of other devices (the papers above fit their
    model parameters on training devices before tracking a test device). Without it the
    curvature of an exponential is barely identifiable from the flat early part of a noisy
    trend, and the median RUL falls back to the straight-line extrapolation.
    """

    mean: float
    sd: float

    @classmethod
    def learn(cls, kind: str, trajectories: list[tuple[FloatArray, FloatArray]]) -> ShapePrior:
        """From ``(flights, h)`` of training units (their true degradation to failure)."""
        if len(trajectories) < 2:
            raise ConfigError("need two or more training units", field="prior")
        shape = SHAPES[kind]
        grid = _GRIDS[shape]
        logs = []
        for n, h in trajectories:
            # the true paths are smooth: weights of a tiny noise make this least squares
            _, loglik = _grid_fit(shape, n, np.asarray(h, dtype=np.float64),
                                  np.full(n.size, 1e8), FIXED_AMPLITUDE.get(kind))
            logs.append(math.log(float(grid[int(np.argmax(loglik))])))
        spread = float(np.std(logs, ddof=1))
        return cls(float(np.mean(logs)), max(spread, 0.05))

    def logpdf(self, theta: FloatArray) -> FloatArray:
        z = (np.log(theta) - self.mean) / self.sd
        out: FloatArray = -0.5 * z * z
        return out


def _grid_fit(shape: str, n: FloatArray, y: FloatArray, w: FloatArray,
              fixed_amp: float | None) -> tuple[tuple[FloatArray, FloatArray], FloatArray]:
    """Per grid value: the amplitude's mean and precision, and the log marginal likelihood."""
    theta = _GRIDS[shape]
    g = basis(shape, theta, n)
    ok = np.isfinite(g).all(axis=1)
    g = np.where(np.isfinite(g), g, 0.0)
    if fixed_amp is not None:
        r = y[None, :] - fixed_amp * g
        amp = np.full(theta.size, fixed_amp)
        loglik = np.where(ok, -0.5 * (r * r) @ w, -np.inf)
        return (amp, np.full(theta.size, np.inf)), loglik
    sgg = (g * g) @ w
    sgy = g @ (w * y)
    ok &= sgg > 0.0
    sgg = np.where(ok, sgg, 1.0)
    amp = sgy / sgg
    rss = float(w @ (y * y)) - sgy * amp
    return (amp, sgg), np.where(ok, -0.5 * rss - 0.5 * np.log(sgg), -np.inf)


def fit_rul(flights: FloatArray, h_est: FloatArray, now: float, kind: str, noise: Noise,
            prior: ShapePrior | None = None, n_draws: int = 2000, seed: int = 0,
            horizon: float = 2000.0) -> RulEstimate:
    """RUL at flight ``now`` of a component of ``kind`` from per-BIT degradation estimates."""
    if kind not in SHAPES:
        raise ConfigError(f"no aging shape for {kind!r}", field="kind")
    shape = SHAPES[kind]
    n_all = np.asarray(flights, dtype=np.float64)
    est = np.asarray(h_est, dtype=np.float64)
    if n_all.size < 3:
        raise ConfigError("need at least three BITs to trend", field="flights")
    cens = noise.censored(est)
    if (~cens).sum() < 2:  # nothing above the dead zone yet: no degradation to trend
        return RulEstimate(math.inf, math.inf, math.inf, np.full(n_draws, math.inf),
                           horizon=horizon)
    n = n_all[~cens]
    y = (est[~cens] - noise.offset) / noise.gain
    sd = noise.sd(y) / noise.gain
    w = 1.0 / (sd * sd)
    theta = _GRIDS[shape]
    (amp, precision), loglik = _grid_fit(shape, n, y, w, FIXED_AMPLITUDE.get(kind))
    if prior is not None:
        loglik = loglik + prior.logpdf(theta)
    post = np.exp(loglik - loglik.max())
    post /= post.sum()
    rng = np.random.default_rng(seed)
    idx = rng.choice(theta.size, size=n_draws, p=post)
    a = amp[idx] + rng.standard_normal(n_draws) / np.sqrt(precision[idx])
    if cens.any() and noise.floor is not None:
        # censored BITs: weight each draw by P(its estimate would sit at the floor)
        h_c = a[:, None] * basis(shape, theta[idx], n_all[cens])
        h_c = np.where(np.isfinite(h_c), h_c, 1e6)
        z = (noise.detection - h_c) / noise.detection_sd
        logw = np.log(np.maximum(ndtr(z), 1e-300)).sum(axis=1)
        wts = np.exp(logw - logw.max())
        pick = rng.choice(n_draws, size=n_draws, p=wts / wts.sum())
        idx, a = idx[pick], a[pick]
    ruls = np.maximum(crossing(shape, theta[idx], a) - now, 0.0)
    ruls = np.where(ruls > horizon, np.inf, ruls)
    q5, q50, q95 = quantiles(ruls)
    return RulEstimate(q50, q5, q95, ruls, horizon=horizon)
