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
per-BIT estimate's *measured* noise, :class:`Noise`, its errors AR(1) from BIT to BIT,
:data:`SERIAL_RHO`), and the grid's marginal likelihoods weight it. Where the noise grows
with the degradation its sd is read at the trend's own path, not at the reading (two
passes: a reading low by chance must not claim a smaller sd and pull the fit low). Draws of
``(parameter, A)`` give the flight where ``h`` crosses 1 in closed form;
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
from scipy.special import ndtr
from scipy.stats import norm
from scipy.stats import t as student_t

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.prognosis.rul import RulEstimate, quantiles
from mapr_daemon.reasoner.prognosis.wear_noise import Noise as Noise
from mapr_daemon.reasoner.prognosis.wear_paths import PathNoise

SHAPES: dict[str, str] = {
    "capacitance": "exponential", "smps_ron_high": "exponential",
    "smps_ron_low": "exponential", "inverter_ron_a_high": "exponential",
    "esr": "reciprocal", "friction": "power",
}
"""The shape family each aging kind is fitted with."""

CLOCK: dict[str, float] = {"exponential": 1.0, "reciprocal": 1.0, "power": 0.0}
"""How the shape parameter scales with the part's life: ``theta ~ life**-c``. A part that
lives a third as long is taken to age along the same path on a clock three times faster,
the assumption behind accelerated aging (an acceleration factor rescales time): an
exponential's rate ``b`` and the reciprocal's ``k`` are rates (``c`` 1: ``b*life``, the
number of e-foldings over the life, is what units share), the power law's exponent ``p``
is a pure number (``c`` 0)."""

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
    return _g(shape, t, x)


def _g(shape: str, t: FloatArray, x: FloatArray) -> FloatArray:
    """``g_t(x)`` element by element (broadcast)."""
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


@dataclasses.dataclass(frozen=True)
class ShapePrior:
    """Fleet knowledge of a kind's aging: ``log(theta) ~ N(mean, sd)``, jointly with the life.

    Learned from run-to-failure units of the same kind (:meth:`learn`), as model-based
    prognostics does with accelerated-aging data of other devices (the papers above fit their
    model parameters on training devices before tracking a test device). Without it the
    curvature of an exponential is barely identifiable from the flat early part of a noisy
    trend, and the median RUL falls back to the straight-line extrapolation.

    Where the amplitude is free, the prior is on ``(log theta, log life)`` (``life`` the
    flight where ``h`` reaches 1): the two are tied (an exponential that bends late must
    start low; :data:`CLOCK`: the shape given the life is the units' shape on the part's own
    clock), and the fleet's spread of lives bounds what a noisy early trend can claim. As
    learned, the pair is normal; :meth:`with_life` holds the life with a Student-t
    (:attr:`life_df`) and keeps the shape's normal conditional given the life.
    ``scatter0 + scatter1*h`` is the sd of the part's own flight-to-flight scatter about
    its smooth aging path (measured on the same units); the trend adds it to the estimate's
    noise, since the threshold is crossed by the smooth path.
    """

    mean: float
    sd: float
    life_mean: float = 0.0
    life_sd: float = 0.0
    """``log(life)`` mean and sd; ``life_sd`` 0: no life prior (a fixed amplitude)."""
    corr: float = 0.0
    scatter0: float = 0.0
    scatter1: float = 0.0
    life_df: float = math.inf
    """Degrees of freedom of the Student-t the life is held with (``inf``: a normal, as
    learned; :meth:`with_life` sets :data:`LIFE_DF`). The shape given the life stays
    normal; only how far the life may stray from ``life_mean`` is heavy-tailed."""

    @classmethod
    def learn(cls, kind: str, trajectories: list[tuple[FloatArray, FloatArray]]) -> ShapePrior:
        """From ``(flights, h)`` of training units (their true degradation to failure)."""
        if len(trajectories) < 3:
            raise ConfigError("need three or more training units", field="prior")
        shape = SHAPES[kind]
        grid = _GRIDS[shape]
        fixed = FIXED_AMPLITUDE.get(kind)
        logs, lives, hs, res = [], [], [], []
        for n, h in trajectories:
            y = np.asarray(h, dtype=np.float64)
            # the paths' scatter is small: weights of a tiny noise make this least squares
            (amp, _), loglik = _grid_fit(shape, n, y, np.full(n.size, 1e8), fixed)
            i = int(np.argmax(loglik))
            logs.append(math.log(float(grid[i])))
            lives.append(math.log(float(crossing(shape, grid[i: i + 1], amp[i: i + 1])[0])))
            fit = amp[i] * basis(shape, grid[i: i + 1], n)[0]
            hs.append(y)
            res.append(np.abs(y - fit) * math.sqrt(math.pi / 2.0))  # E|e| -> sd
        s1, s0 = np.polyfit(np.concatenate(hs), np.concatenate(res), 1)
        s1 = max(float(s1), 0.0)
        s0 = max(float(s0), 1e-3)
        spread = max(float(np.std(logs, ddof=1)), 0.05)
        if fixed is not None:
            return cls(float(np.mean(logs)), spread, scatter0=s0, scatter1=s1)
        life_sd = max(float(np.std(lives, ddof=1)), 0.02)
        # the shape on the part's own clock (CLOCK): what the units share whatever their life
        c = CLOCK[shape]
        own = max(float(np.std(np.add(logs, np.multiply(c, lives)), ddof=1)), 0.05)
        sd = math.hypot(own, c * life_sd)
        return cls(float(np.mean(logs)), sd, float(np.mean(lives)), life_sd,
                   0.0 - c * life_sd / sd, s0, s1)

    def life_flights(self, kind: str) -> float:
        """The median life (flights from new to the threshold) this prior expects."""
        if self.life_sd > 0.0:
            return math.exp(self.life_mean)
        amp = FIXED_AMPLITUDE.get(kind, 1.0)
        return float(crossing(SHAPES[kind], np.array([math.exp(self.mean)]),
                              np.array([amp]))[0])

    def with_life(self, kind: str, life_sd: float, life_flights: float | None = None,
                  life_df: float | None = None) -> ShapePrior:
        """The same aging *shape*, with the life held as ``log(life)`` Student-t about
        ``log(life_flights)`` with scale ``life_sd`` and ``life_df`` degrees of freedom
        (``life_flights`` None: this prior's own median life; ``life_df`` None:
        :data:`LIFE_DF`; ``inf``: a normal, the prior as it was before issue 28).

        What the training units tell reliably is the shape of aging given a life (an
        exponential that fails late bends late: the conditional of ``log theta`` given
        ``log life``, kept here exactly); the absolute life is the aging model's assumption
        (200 flights), not the user's fleet, and a trend held to it by the training units'
        own spread (sd 0.17 in the logarithm) states intervals that miss when the real parts
        live twice or half as long. ``life_sd`` is never narrowed below the learned spread.
        For a fixed-amplitude kind the shape parameter *is* the life (``theta = c/life``),
        so its mean moves with the life and its sd becomes ``life_sd``.

        Why heavy tails: a normal on ``log(life)`` charges a unit that lives a third of the
        prior's life ``(ln 3/sd)**2/2`` nats however strongly its own readings say so, and the
        charge grows without bound the further off the prior is; a Student-t charges about
        the same near the centre but only ``(df+1)/2*log(z**2/df)`` far out, so a trend that
        clearly disagrees with the fleet wins, while a trend that says little (early life,
        noisy readings) still leans on the fleet's life, with wider bounds."""
        df = LIFE_DF if life_df is None else life_df
        sd = max(life_sd, self.life_sd if self.life_sd > 0.0 else self.sd)
        target = math.log(life_flights if life_flights is not None
                          else self.life_flights(kind))
        if self.life_sd <= 0.0:
            shift = target - math.log(self.life_flights(kind))
            return dataclasses.replace(self, mean=self.mean - shift, sd=sd, life_df=df)
        c = CLOCK[SHAPES[kind]]
        # log theta + c*log life: the shape on the part's own clock, as the units showed it
        own = math.sqrt(max(self.sd ** 2 + (c * self.life_sd) ** 2
                            + 2.0 * c * self.corr * self.sd * self.life_sd, 0.05 ** 2))
        sd_t = math.hypot(own, c * sd)
        return dataclasses.replace(
            self, mean=self.mean - c * (target - self.life_mean), sd=sd_t, life_mean=target,
            life_sd=sd, corr=0.0 - c * sd / sd_t, life_df=df)

    def logpdf(self, theta: FloatArray) -> FloatArray:
        """Log density of the shape parameter alone (up to a constant): normal, or, where the
        amplitude is fixed and the shape parameter *is* the life (``theta = c/life``), with
        the life's tails (:attr:`life_df`)."""
        z = (np.log(theta) - self.mean) / self.sd
        return _standard_logpdf(z, self.life_df)

    def joint_logpdf(self, theta: FloatArray, life: FloatArray) -> FloatArray:
        """Log density of ``(theta, life)`` on their grid ``(theta, life)`` (up to a
        constant): the life's marginal (normal or Student-t, :attr:`life_df`) times the
        shape's normal conditional given the life (with ``life_df`` inf, the joint normal)."""
        zl = ((np.log(life) - self.life_mean) / self.life_sd)[None, :]
        r = self.corr
        cond = (np.log(theta) - self.mean)[:, None] - r * self.sd * zl
        zc = cond / (self.sd * math.sqrt(1.0 - r * r))
        out: FloatArray = -0.5 * zc * zc + _standard_logpdf(zl, self.life_df)
        return out

    def scatter(self, h: FloatArray) -> FloatArray:
        out: FloatArray = self.scatter0 + self.scatter1 * np.clip(h, 0.0, 1.5)
        return out


def life_width(prior: ShapePrior, kind: str) -> float:
    """The width of the prior's central :data:`SHARE_INTERVAL` interval of ``log(life)``:
    the life's Student-t (or normal) where the amplitude is free, the shape parameter's
    where it is fixed (``theta = c/life``: the same width)."""
    scale = prior.life_sd if prior.life_sd > 0.0 else prior.sd
    q = 0.5 + SHARE_INTERVAL / 2.0
    z = float(student_t.ppf(q, prior.life_df)) if math.isfinite(prior.life_df) \
        else float(norm.ppf(q))
    return 2.0 * z * scale


def prior_share(prior: ShapePrior | None, kind: str, age: float, rul: RulEstimate) -> float:
    """How much of the fleet prior's spread of the part's life the unit's own readings have
    left: the width of the posterior's central :data:`SHARE_INTERVAL` interval of
    ``log(life)`` (``life = age + RUL``, from the trend's draws) over the prior's
    (:func:`life_width`). About 1: the readings have told little yet, and the RUL is mostly
    the prior's assumed life; near 0: the unit's trend has placed its own life. ``inf``
    where more than the interval's tail of the draws never cross within the horizon; NaN
    without a prior."""
    if prior is None:
        return math.nan
    draws = np.asarray(rul.draws, dtype=np.float64)
    if draws.size == 0:
        return math.nan
    tail = (1.0 - SHARE_INTERVAL) / 2.0
    if np.mean(~np.isfinite(draws)) > tail:
        return math.inf
    life = np.maximum(age + draws[np.isfinite(draws)], 1e-3)
    lo, hi = np.quantile(np.log(life), [tail, 1.0 - tail])
    return float((hi - lo) / max(life_width(prior, kind), 1e-9))


SHARE_INTERVAL = 0.90
"""The central interval :func:`prior_share` compares (the RUL's own interval)."""
LEANS = 0.25
"""A :func:`prior_share` above which a RUL is mostly the prior's assumed life, not the unit's
trend: where nobody stated the life, the headline RUL is withheld with that reason
(:mod:`.assessment`). Measured, not chosen: on five kept design catalogs of
``bench/fleet_rul.py --readback --reassess`` (mean lives 70, 100 and 200 flights against the
prior's 200; the true kind's RUL from a quarter of life on, as the bench prints it by share),
RULs with a share under 0.10 were within 20 % of the truth at 55-69 % of the points (1.00-1.18x
the truth, 90 % interval coverage 87-99 %); from 0.25 on at 0-11 % (1.4-4.7x), and on the
70-flight units the interval held the truth at 9-89 % (the prior's life was wrong, and
nothing in the readings said so yet). docs/reasoner-measured.md, "A RUL that is the prior's,
not the unit's"."""


def _standard_logpdf(z: FloatArray, df: float) -> FloatArray:
    """Log density of a standard normal (``df`` inf) or Student-t, up to a constant."""
    if math.isinf(df):
        out: FloatArray = -0.5 * z * z
    else:
        out = -0.5 * (df + 1.0) * np.log1p(z * z / df)
    return out


LIVES: FloatArray = np.logspace(1.0, 4.3, 331)
"""Lives (flights from 0 to the threshold) of the joint grid: 10 to 20,000 flights."""
LIFE_SD = 1.0
"""How loosely the fleet prior holds a life nobody stated: the scale of ``log(life)``'s
Student-t (:data:`LIFE_DF`; a factor of 2.7 either way at one scale). 0.7 (a normal) was
chosen on kept fleet catalogs with the prior's life off by a factor of two either way
(docs/reasoner-measured.md, "The fleet prior's life: how 0.7 was chosen"); once the shape
given the life ran on the part's own clock (:data:`CLOCK`, issue 28), 1.0 with
:data:`LIFE_DF` held the true RUL at more points on units living 70 flights and scored
alpha-lambda as well or better at 200 and 400 (design seeds; docs/reasoner-measured.md,
"Fast-aging units")."""
LIFE_DF = 2.0
"""Degrees of freedom of the Student-t a life is held with (:meth:`ShapePrior.with_life`):
a unit whose own trend clearly says it lives three or five times shorter or longer than
the fleet's life is not charged without bound for it, as a normal charges it (the normal's
``z**2/2`` against the t's ``3/2*log(1 + z**2/2)``: 4.5 against 2.1 nats at ``z`` = 3)."""


SERIAL_RHO = 0.14
"""Correlation of successive BITs' standardised estimate errors (AR(1), one step per
successive trended BIT): the trend's likelihood whitens its residuals with it
(:func:`_whiten`), so a run of low readings counts for less than as many independent ones
and the interval widens to match. Measured, not chosen: the pooled lag-one correlation of
``(estimate - truth)/stated sd`` over the run-to-failure units of three kept design
catalogs of ``bench/fleet_rul.py`` (mean lives 70, 200 and 400 flights; 20 units, 693 BITs;
+0.26, +0.10 and +0.12 apart; the bench prints it). The calibration BITs cannot measure it
(each is a unit of its own at one degradation) nor the fleet prior's training units (their
true paths only, no estimates); docs/reasoner-measured.md, "Fast-aging units"."""


UNIT_OFFSET_SD: dict[str, float] = {"esr": 0.016}
"""Per kind, the sd of a unit's persistent estimator offset ``c`` (in ``h``, about 0): the
trend fits ``h_est = c + A*g_theta(n)`` with ``c ~ N(0, sd**2)``, linear-Gaussian with ``A``
and marginalised with it (:func:`_grid_fit`, :func:`_joint_draws`); a kind not listed has
none (``c`` = 0). An offset the trend does not know reads as wear or its absence: ESR read
0.02-0.03 low on a unit all its life turns, through the reciprocal's fixed amplitude, into a
crossing several flights late on a fast part (issue 28). Measured, not chosen: each unit's
mean of ``estimate - truth`` over its BITs, the mean square over units less its sampling
part (the errors' variance over the unit's BITs, inflated for :data:`SERIAL_RHO`), on 38
run-to-failure units of six kept catalogs of ``bench/fleet_rul.py`` (lives 70-400 flights;
the bench prints it per kind): ESR 0.016 (all 10 units low, mean -0.019; as far from 0 by
sampling alone: chance 0.001). The other kinds' units' mean errors are what sampling gives
(chance 0.37 friction, 0.69 capacitance, 0.97 SMPS high-side Ron; 5 % is the bar): no offset
(friction's 0.011, had it been kept, moved its coverage on the design catalogs down, not up).
docs/reasoner-measured.md, "A unit's persistent estimator offset"."""
UNIT_OFFSET_MEAN: dict[str, float] = {"esr": -0.019}
"""Per kind, the mean of the units' offsets, measured with :data:`UNIT_OFFSET_SD` (the same
38 units): the prior on ``c`` is ``N(mean, sd**2)``. ESR's units all read low (-0.003 to
-0.031, mean -0.019): the prognostic model's calibration BITs place ESR's readings at flight
conditions a little high, and a reciprocal with a fixed amplitude turns that into a late
crossing (from half life on 1.31x the true RUL on the 70-flight design catalog; 1.16x with
the mean). It is the shipped model's (the demo pair's) calibration that was measured: a
model built from other calibration BITs carries its own."""


FLIGHT_NOISE: dict[str, tuple[float, float]] = {"friction": (-0.213, 0.690)}
"""Per kind, ``(a, b)``: how much more a BIT flown on a flight scatters than the prognostic
model's calibration BITs say, ``log(sd on flights / stated sd) = a + b*h`` at the true
degradation ``h``; the trend reads a BIT's sd as the stated one times
:func:`flight_noise_factor` (``max(1, exp(a + b*h))``: never narrower than the calibration
states). Friction's estimates scatter 1.6 times the stated sd at the threshold (1.2 at 0.6)
and 0.8 times it when new: the calibration's sd grows with the wear, the flights' grows
faster, so a friction unit's interval near its threshold was too narrow (issue 28: the
90 % interval held the truth at 71 % of the BITs from half life on, 70-flight units).
Measured, not chosen: ``log(|error|/stated sd)`` on ``h`` by least squares (corrected by
``E log|z|`` and rescaled to unit mean square, as :func:`.wear_noise._fit_log_sd` fits
the calibration's) over the run-to-failure units of eleven kept catalogs of
``bench/fleet_rul.py`` (lives 70-400 flights, the demo pair; friction 586 BITs of 19 units,
slope 90 % interval by units +0.46..+0.93). Capacitance (+0.01 - 0.07 h) and SMPS
high-side Ron (-0.24 - 0.08 h) scatter no more than stated: none. ESR (-0.26 + 0.41 h,
629 BITs of 20 units: 1.16 at the threshold, 0.77 when new) is left out: its intervals
already held the truth at 95-99 % of the design catalogs' BITs, the factor changed
none of their figures, and on the synthetic 66-flight ESR units of the unit tests (read
with the calibration's sd, no excess) it moved the coverage from 86 % to 84 %. Like
:data:`UNIT_OFFSET_MEAN` it is the shipped model's calibration that was measured
(docs/reasoner-measured.md, "Friction near its threshold")."""


def flight_noise_factor(kind: str, h: FloatArray) -> FloatArray:
    """The factor :data:`FLIGHT_NOISE` puts on a BIT's stated sd at degradation ``h``."""
    a, b = FLIGHT_NOISE.get(kind, (0.0, 0.0))
    out: FloatArray = np.maximum(1.0, np.exp(a + b * np.clip(h, 0.0, 1.5)))
    return out


def _whiten(x: FloatArray, rho: float, chain: int | None = None) -> FloatArray:
    """AR(1) prewhitening along the last axis of standardised residuals (``x`` already
    divided by their sd): ``u_0 = x_0``, ``u_i = (x_i - rho x_{i-1}) / sqrt(1 - rho**2)``;
    the ``u`` are independent unit normals when the ``x`` are AR(1) with ``rho``, so sums
    of their squares are the correlated likelihood (its log-determinant is fixed by
    ``rho`` and the weights alone, the same at every grid value). The step is per
    successive BIT, not per flight: what correlates the errors (the estimator's bias moving
    slowly with the degradation and the unit) is not a clock. ``chain``: only the first
    ``chain`` columns are the BITs' chain; the rest (in-flight observations, another
    estimator's errors) stay independent."""
    k = x.shape[-1] if chain is None else min(chain, x.shape[-1])
    if rho == 0.0 or k < 2:
        return x
    out = np.array(x, dtype=np.float64, copy=True)
    out[..., 1:k] = (x[..., 1:k] - rho * x[..., :k - 1]) / math.sqrt(1.0 - rho * rho)
    return out


def _offset_column(n_obs: int, s: FloatArray, rho: float, chain: int | None,
                   on: FloatArray | None = None) -> FloatArray:
    """The unit offset's column in the whitened least squares: 1 on every BIT of the chain
    (the BIT estimator's bias; ``on``: only where it is 1, the BITs read by a path that
    takes the fleet's offset), 0 on the extra observations (another estimator's), weighted
    and whitened as the residuals are."""
    k = n_obs if chain is None else min(chain, n_obs)
    ones = np.zeros(n_obs)
    ones[:k] = 1.0 if on is None else np.asarray(on, dtype=np.float64)[:k]
    out: FloatArray = _whiten(ones * s, rho, chain)
    return out


def _joint_draws(shape: str, n: FloatArray, y: FloatArray, w: FloatArray, prior: ShapePrior,
                 n_draws: int, rng: np.random.Generator, rho: float = 0.0,
                 chain: int | None = None, offset_sd: float = 0.0,
                 offset_on: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Draws of ``(theta, A)`` from the posterior on the ``(theta, life)`` grid, where the
    amplitude is the one that puts ``h = 1`` at the life: ``A = 1/g_theta(life)``; the
    errors AR(1) with ``rho`` per successive BIT; the BITs' unit offset ``c ~ N(0,
    offset_sd**2)`` marginalised (given ``(theta, A)`` the residual is linear in ``c``)."""
    theta = _GRIDS[shape]
    s = np.sqrt(w)
    g = _whiten(basis(shape, theta, n) * s, rho, chain)
    yw = _whiten(y * s, rho, chain)
    amp = 1.0 / np.maximum(basis(shape, theta, LIVES), 1e-300)
    sgg, sgy, syy = (g * g).sum(axis=1), g @ yw, float(yw @ yw)
    loglik = -0.5 * (syy - 2.0 * amp * sgy[:, None] + amp * amp * sgg[:, None])
    if offset_sd > 0.0:
        o = _offset_column(y.size, s, rho, chain, offset_on)
        soo = float(o @ o) + 1.0 / offset_sd ** 2
        proj = float(o @ yw) - amp * (g @ o)[:, None]   # o . (y - A g), whitened
        loglik = loglik + 0.5 * proj * proj / soo
    loglik = loglik + prior.joint_logpdf(theta, LIVES)
    post = np.exp(loglik - loglik.max()).ravel()
    pick = rng.choice(post.size, size=n_draws, p=post / post.sum())
    it, il = np.divmod(pick, LIVES.size)
    # jitter within the grid cell, in the logarithm: each cell's own width (the power grid is
    # linear, the others and the lives log-spaced)
    cell = np.gradient(np.log(theta))
    lt = np.log(theta[it]) + cell[it] * (rng.random(n_draws) - 0.5)
    ll = np.log(LIVES[il]) + math.log(LIVES[1] / LIVES[0]) * (rng.random(n_draws) - 0.5)
    th, life = np.exp(lt), np.exp(ll)
    a: FloatArray = 1.0 / np.maximum(_g(shape, th, life), 1e-300)
    return th, a


def _grid_fit(shape: str, n: FloatArray, y: FloatArray, w: FloatArray,
              fixed_amp: float | None, rho: float = 0.0, chain: int | None = None,
              offset_sd: float = 0.0, offset_on: FloatArray | None = None
              ) -> tuple[tuple[FloatArray, FloatArray], FloatArray]:
    """Per grid value: the amplitude's mean and precision, and the log marginal likelihood
    (weighted least squares, the errors AR(1) with ``rho`` per successive BIT; with
    ``offset_sd`` > 0 the BITs' unit offset ``c ~ N(0, offset_sd**2)`` is a second linear
    parameter, marginalised: the amplitude's mean and precision are its marginal's)."""
    theta = _GRIDS[shape]
    g = basis(shape, theta, n)
    ok = np.isfinite(g).all(axis=1)
    g = np.where(np.isfinite(g), g, 0.0)
    s = np.sqrt(w)
    o = _offset_column(y.size, s, rho, chain, offset_on) if offset_sd > 0.0 else None
    soo = 0.0 if o is None else float(o @ o) + 1.0 / offset_sd ** 2
    if fixed_amp is not None:
        r = _whiten((y[None, :] - fixed_amp * g) * s, rho, chain)
        amp = np.full(theta.size, fixed_amp)
        rss = (r * r).sum(axis=1)
        if o is not None:
            rss = rss - (r @ o) ** 2 / soo
        loglik = np.where(ok, -0.5 * rss, -np.inf)
        return (amp, np.full(theta.size, np.inf)), loglik
    g = _whiten(g * s, rho, chain)
    yw = _whiten(y * s, rho, chain)
    sgg = (g * g).sum(axis=1)
    sgy = g @ yw
    syy = float(yw @ yw)
    if o is not None:   # Schur complement of the offset: the amplitude's marginal
        sog, soy = g @ o, float(o @ yw)
        sgg = sgg - sog * sog / soo
        sgy = sgy - sog * soy / soo
        syy = syy - soy * soy / soo
    ok &= sgg > 0.0
    sgg = np.where(ok, sgg, 1.0)
    amp = sgy / sgg
    rss = syy - sgy * amp
    return (amp, sgg), np.where(ok, -0.5 * rss - 0.5 * np.log(sgg), -np.inf)


def _posterior_draws(shape: str, n: FloatArray, y: FloatArray, w: FloatArray,
                     prior: ShapePrior | None, fixed: float | None, n_draws: int,
                     rng: np.random.Generator, rho: float, chain: int, offset_sd: float,
                     offset_on: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Draws of ``(theta, A)`` given the observations' weights ``w``: on the joint
    ``(theta, life)`` grid where the prior holds a life (:func:`_joint_draws`), else on the
    shape's grid with the amplitude linear-Gaussian (or ``fixed``)."""
    if prior is not None and fixed is None and prior.life_sd > 0.0:
        return _joint_draws(shape, n, y, w, prior, n_draws, rng, rho, chain, offset_sd,
                            offset_on)
    theta = _GRIDS[shape]
    (amp, precision), loglik = _grid_fit(shape, n, y, w, fixed, rho, chain, offset_sd,
                                         offset_on)
    if prior is not None:
        loglik = loglik + prior.logpdf(theta)
    post = np.exp(loglik - loglik.max())
    post /= post.sum()
    idx = rng.choice(theta.size, size=n_draws, p=post)
    th = theta[idx]
    if fixed is not None:
        # the shape parameter alone sets the crossing: spread each draw over its grid
        # cell (in the logarithm), or a well-read unit's interval collapses to one cell,
        # 3 % of the life wide (a flight or two of a short life's RUL), and misses
        th = np.exp(np.log(th) + np.gradient(np.log(theta))[idx]
                    * (rng.random(n_draws) - 0.5))
    a: FloatArray = amp[idx] + rng.standard_normal(n_draws) / np.sqrt(precision[idx])
    return th, a


def fit_rul(flights: FloatArray, h_est: FloatArray, now: float, kind: str,
            noise: Noise | PathNoise,
            prior: ShapePrior | None = None, n_draws: int = 2000, seed: int = 0,
            horizon: float = 2000.0, conditions: FloatArray | None = None,
            rho: float | None = None,
            extra: tuple[FloatArray, FloatArray, FloatArray] | None = None,
            offset_sd: float | None = None, offset_mean: float | None = None) -> RulEstimate:
    """RUL at flight ``now`` of a component of ``kind`` from per-BIT degradation estimates;
    ``conditions (n, 3)``: each BIT's scaled flight condition (NaN rows unknown), at which
    the noise model reads its estimate and weighs it (:meth:`Noise.calibrate`,
    :meth:`Noise.h_sd`); ``rho``: the correlation of successive BITs' standardised errors
    (None: :data:`SERIAL_RHO`). ``extra``: other observations of the same degradation
    ``(flights, h, sd)``, already in ``h`` with their own sd and independent errors (the
    in-flight tracker's, :mod:`.fusion`); with them fewer than three BITs may trend, as long
    as three flights are observed. ``offset_mean``/``offset_sd``: the prior on the BITs'
    persistent unit offset ``c`` (None: the kind's :data:`UNIT_OFFSET_MEAN` and
    :data:`UNIT_OFFSET_SD`; sd 0: ``c`` fixed at the mean). A BIT's sd is read at the
    degradation the trend's own path puts it at, not at its reading, and times
    :func:`flight_noise_factor` (the kind's flights' excess scatter). ``noise``: one for
    every BIT, or each BIT's path's (:class:`~.wear_paths.PathNoise`: a unit commissioned
    after it had flown has readings of both paths); the unit offset is then on the BITs of
    the paths that take the fleet's (not on those read against the unit's own baseline),
    one ``c`` for all of them (one chain of errors: the BITs in their order)."""
    if kind not in SHAPES:
        raise ConfigError(f"no aging shape for {kind!r}", field="kind")
    shape = SHAPES[kind]
    n_all = np.asarray(flights, dtype=np.float64)
    est = np.asarray(h_est, dtype=np.float64)
    xn, xh, xsd = (np.zeros(0), np.zeros(0), np.zeros(0)) if extra is None else (
        np.asarray(extra[0], dtype=np.float64), np.asarray(extra[1], dtype=np.float64),
        np.asarray(extra[2], dtype=np.float64))
    if np.unique(np.concatenate((n_all, xn))).size < 3 or (extra is None and n_all.size < 3):
        raise ConfigError("need at least three BITs (or flights observed) to trend",
                          field="flights")
    paths = noise if isinstance(noise, PathNoise) else PathNoise.one(noise, est.size)
    cens = paths.censored(est) if est.size else np.zeros(0, dtype=bool)
    if (~cens).sum() + xn.size < 2:  # nothing above the dead zone yet: no degradation to trend
        return RulEstimate(math.inf, math.inf, math.inf, np.full(n_draws, math.inf),
                           horizon=horizon)
    kept = paths.take(~cens)
    on = kept.fleet_offset   # 1 on the BITs whose path takes the fleet's unit offset
    c = None if conditions is None else np.asarray(conditions, dtype=np.float64)[~cens]
    mu_c = UNIT_OFFSET_MEAN.get(kind, 0.0) if offset_mean is None else offset_mean
    y_bit = kept.calibrate(est[~cens], c) - mu_c * on if (~cens).any() else np.zeros(0)
    chain = y_bit.size   # the BITs' AR(1) chain comes first, the extra observations after
    n = np.concatenate((n_all[~cens], xn))
    y = np.concatenate((y_bit, xh))
    r1 = SERIAL_RHO if rho is None else rho
    fixed = FIXED_AMPLITUDE.get(kind)
    sd_c = UNIT_OFFSET_SD.get(kind, 0.0) if offset_sd is None else offset_sd
    if chain == 0 or not on.any():
        sd_c = 0.0   # no BIT to carry the offset

    def weights(level: FloatArray) -> FloatArray:
        """Inverse variances of the observations, each read at degradation ``level``."""
        bit = level[:chain]
        var = np.concatenate(((kept.h_sd(bit, c) * flight_noise_factor(kind, bit)) ** 2
                              if chain else np.zeros(0), xsd ** 2))
        if prior is not None:
            var = var + prior.scatter(level) ** 2
        out: FloatArray = 1.0 / np.maximum(var, 1e-12)
        return out

    def draws(w: FloatArray) -> tuple[FloatArray, FloatArray, np.random.Generator]:
        """The posterior's draws under weights ``w`` (each pass from the same seed), and
        the generator they were drawn from."""
        gen = np.random.default_rng(seed)
        return (*_posterior_draws(shape, n, y, w, prior, fixed, n_draws, gen, r1, chain,
                                  sd_c, on), gen)

    # The noise grows with the degradation (friction's sd nearly doubles from new to the
    # threshold), so the sd of a reading is the sd at the unit's TRUE degradation, not at the
    # reading: read at the reading, a reading low by chance claims a smaller sd and weighs
    # more than one high by chance, and the fit leans low (late crossings: friction from half
    # life on 1.15x the true RUL on design catalogs, 1.03x with one sd for all). The first
    # pass reads the sd at the readings; the trend's own path at each observation (the
    # draws' median) is then the level the second, final pass reads it at. A noise that
    # does not grow with the degradation needs no second pass.
    w = weights(y)
    th, a, rng = draws(w)
    if not np.array_equal(w, weights(np.zeros_like(y))):
        path = a[:, None] * basis(shape, th, n)
        level = np.median(np.where(np.isfinite(path), path, 1e6), axis=0)
        th, a, rng = draws(weights(np.clip(level, 0.0, None)))
    if cens.any() and paths.has_floor:
        # censored BITs: weight each draw by P(its estimate would sit at the floor)
        h_c = a[:, None] * basis(shape, th, n_all[cens])
        h_c = np.where(np.isfinite(h_c), h_c, 1e6)
        detection, detection_sd = paths.take(cens).detection()
        z = (detection - h_c) / detection_sd
        logw = np.log(np.maximum(ndtr(z), 1e-300)).sum(axis=1)
        wts = np.exp(logw - logw.max())
        pick = rng.choice(n_draws, size=n_draws, p=wts / wts.sum())
        th, a = th[pick], a[pick]
    ruls = np.maximum(crossing(shape, th, a) - now, 0.0)
    ruls = np.where(ruls > horizon, np.inf, ruls)
    q5, q50, q95 = quantiles(ruls)
    return RulEstimate(q50, q5, q95, ruls, horizon=horizon)
