"""What the RUL figures can be at a given per-BIT estimate noise: the trend's ceiling.

    python3 bench/rul_ceiling.py [--units-per-kind 10] [--noise 0,0.03,0.05,0.08,0.11]
                                 [--mean-life 200] [--bit-every 4] [--seed N]
                                 [--lives 70,100,200,400 --prior unstated]

Run-to-failure units of each trended kind (:func:`mapr_daemon.ema.degradation.trajectory`,
fresh seeds each run, printed), a BIT every ``--bit-every`` flights. Each BIT's degradation
estimate is the unit's TRUE degradation plus Gaussian noise of sd ``sigma`` (in units of
the failure threshold), and the trend is told that sd exactly: the estimator is perfect but
for its noise, unbiased, its noise known, no leading mode to choose, no evidence gate. What
this bench scores is therefore the trend itself
(:func:`mapr_daemon.reasoner.prognosis.trend.fit_rul`
with the product's fleet prior, :func:`~mapr_daemon.reasoner.training.rul_scoring.learn_prior`) at
that
noise, with the same rules as bench/fleet_rul.py (bench/rul_scoring.py): alpha-lambda (alpha
0.2, lambda 0.5 and 0.75) by the median, and coverage of the 90 % interval at every BIT from a
quarter of life on.

``--lives`` scores units of several mean lives in turn (each with its own unit seeds, drawn
from the run's seed) against one fleet prior learned at 200 flights: ``--prior learned``
holds that life as tightly as the training units' spread (as before), ``--prior unstated``
as the daemon holds a life nobody stated (:meth:`~mapr_daemon.reasoner.prognosis.trend
.ShapePrior.with_life` with :data:`~mapr_daemon.reasoner.prognosis.trend.LIFE_SD`): how the
trend does on parts that live a third, half or twice as long as the prior says (issue 28).

Read beside bench/fleet_rul.py, whose per-BIT estimates err by sd 0.07-0.11 of the threshold
(it prints them): the figure at that sigma is what the product can reach with the
estimators it has; ``sigma = 0`` is the ceiling of the trend and prior alone.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
from rul_scoring import Point, kind_summary, score_points
from seeds import master

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.ema.degradation import trajectory
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.prognosis import soh, trend
from mapr_daemon.reasoner.training.rul_scoring import bit_flights, learn_prior

KINDS = ("capacitance", "esr", "friction", "smps_ron_high")
LAMBDAS = (0.5, 0.75)
ALPHA = 0.2
SEED_BASE = 1_000_000_000
"""Unit seeds are drawn above this, clear of the fleet prior's training units (10,000 up)."""
MIN_SD = 0.005
"""The sd the trend is told at ``sigma = 0`` (a zero sd would make its weights infinite)."""


def unit_points(kind: str, seed: int, sigma: float, bit_every: int, mean_life: float,
                prior: trend.ShapePrior, params: ActuatorParams) -> tuple[float, list[Point]]:
    """One unit's stated RUL at each BIT from a quarter of its life on."""
    t = trajectory(params, kind, int(mean_life * 2), seed, mean_life)
    fl = bit_flights(t, bit_every)
    h = np.array([soh.degradation(params, kind, float(t.values[int(f)])) for f in fl])
    est = h + sigma * np.random.default_rng(seed + 1).standard_normal(fl.size)
    noise = trend.Noise(max(sigma, MIN_SD))
    pts = []
    for j in range(3, fl.size):
        now = float(fl[j])
        true = t.eol_flight - now
        if now < 0.25 * t.eol_flight or true <= 0:
            continue
        r = trend.fit_rul(fl[: j + 1], est[: j + 1], now, kind, noise, prior, seed=j)
        pts.append(Point(now, true, r.rul, r.lower, r.upper, None))
    return t.eol_flight, pts


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units-per-kind", type=int, default=10)
    ap.add_argument("--noise", default="0,0.03,0.05,0.08,0.11",
                    help="per-BIT estimate sd values, in units of the failure threshold")
    ap.add_argument("--mean-life", type=float, default=200.0,
                    help="mean life of the units (the fleet prior's: 200 flights)")
    ap.add_argument("--lives", help="several mean lives, comma-separated (overrides "
                    "--mean-life)")
    ap.add_argument("--prior", choices=("learned", "unstated"), default="learned",
                    help="the fleet prior's life held as learned, or as the daemon holds a "
                         "life nobody stated")
    ap.add_argument("--bit-every", type=int, default=4)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--seed", type=int)
    args = ap.parse_args()
    argv = sys.argv[1:]
    rest = [a for i, a in enumerate(argv) if not a.startswith("--seed")
            and not (i > 0 and argv[i - 1] == "--seed")]
    seed = master(args.seed, " ".join(["python3 bench/rul_ceiling.py", *rest]))
    rng = np.random.default_rng(seed)
    params = load_actuator(default_actuator_path())
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    sigmas = [float(s) for s in args.noise.split(",")]
    priors = {k: learn_prior(params, k, 30) for k in kinds}
    if args.prior == "unstated":
        priors = {k: p.with_life(k, trend.LIFE_SD) for k, p in priors.items()}
    print("fleet prior: learned at 200 flights, its life held "
          + ("as learned" if args.prior == "learned" else
             f"as a life nobody stated (scale {trend.LIFE_SD:g}, "
             f"{getattr(trend, 'LIFE_DF', float('inf')):g} degrees of freedom; inf: a "
             "normal, the code before issue 28)"))
    lives = [float(v) for v in args.lives.split(",")] if args.lives else [args.mean_life]
    wall, cpu = time.monotonic(), time.process_time()
    for life in lives:
        units = [(k, int(rng.integers(SEED_BASE, 2 * SEED_BASE)))
                 for k in kinds for _ in range(args.units_per_kind)]
        print(f"\n#### {len(units)} units ({args.units_per_kind} per kind), mean life "
              f"{life:g} flights, a BIT every {args.bit_every}; unit seeds "
              + ", ".join(f"{k}={s}" for k, s in units))
        one_life(units, sigmas, args.bit_every, life, priors, params, kinds)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    print(f"\n{time.monotonic() - wall:.0f} s wall, {time.process_time() - cpu:.0f} s CPU, "
          f"peak memory {usage.ru_maxrss / 1024:.0f} MB, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min)")
    return 0


def one_life(units: list[tuple[str, int]], sigmas: list[float], bit_every: int,
             mean_life: float, priors: dict[str, trend.ShapePrior], params: ActuatorParams,
             kinds: list[str]) -> None:
    """Score ``units`` of one mean life at each noise and print the table."""
    print(f"\n{'sigma':>6}  alpha-lambda (all, worst kind)  coverage (all, worst kind, worst "
          "unit)   per kind: alpha-lambda / coverage")
    for sigma in sigmas:
        scores = []
        for i, (kind, s) in enumerate(units):
            eol, pts = unit_points(kind, s, sigma, bit_every, mean_life,
                                   priors[kind], params)
            scores.append(score_points(f"U{i + 1:02d}", kind, eol, pts, LAMBDAS, ALPHA,
                                       leads=False))
        per_kind = {}
        for k in kinds:
            ks = [sc for sc in scores if sc.kind == k]
            al = [v for sc in ks for v in sc.alpha_lambda.values()]
            cov = [p.covered for sc in ks for p in sc.points]
            per_kind[k] = (100 * sum(al) / len(al), 100 * float(np.mean(cov)))
        al = [v for sc in scores for v in sc.alpha_lambda.values()]
        cov = [p.covered for sc in scores for p in sc.points]
        worst_unit = min(sc.coverage for sc in scores)
        print(f"{sigma:6.3f}  {100 * sum(al) / len(al):5.1f} % ({sum(al)}/{len(al)}), "
              f"{min(v[0] for v in per_kind.values()):5.1f} %       "
              f"{100 * float(np.mean(cov)):5.1f} %, {min(v[1] for v in per_kind.values()):5.1f}"
              f" %, {100 * worst_unit:5.1f} %     "
              + "  ".join(f"{k} {a:.0f}/{c:.0f}" for k, (a, c) in per_kind.items()),
              flush=True)
        if sigma == sigmas[-1]:
            for k in [*kinds, "all"]:
                print("   " + kind_summary(k, [sc for sc in scores
                                               if k == "all" or sc.kind == k]))


if __name__ == "__main__":
    sys.exit(main())
