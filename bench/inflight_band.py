"""The in-flight change's stated band and the fused RUL, in memory (issue 29).

Run-to-failure friction units along the aging model's shape (``1 + 2 (n/life)^1.5``, life
``--mean-life`` +/- 30 %), each unit off the data sheet by a lognormal 20 %, each flight's
friction the path times its own scatter (lognormal ``--scatter``, the grease) read by the
tracker with a relative sd of ``--tracker`` (its own error, Gaussian). The flights' rows go
through :class:`~mapr_daemon.reasoner.inflight.baseline.Baseline` as the daemon stores them
(the baseline from the first three flights, the sd learned per unit:
``reasoner/inflight/scatter.py``); the truth is the path's change from new. Printed:

* per flight: the change's error against the path, in failure thresholds, its sd over the
  mean stated sd, and how often the stated 90 % band holds the path;
* the RUL at 50 % and 75 % of each unit's life with a PBIT every flight (the BIT's estimate
  drawn from the prognostic model's measured friction noise at the flight's own friction:
  ``--bit-grease shared``, the same grease as the flight's in-flight estimate, as one flight
  of the plant flies both; ``independent``, a grease of its own), BITs only beside BITs +
  in-flight fused as the product fuses them (``reasoner/prognosis/fusion.py``: the
  baseline's common error marginalised) and, for comparison, with every in-flight
  observation's total sd as if independent: alpha-lambda (alpha 0.2, point criterion as
  ``bench/fleet_rul.py`` scores it) and the 90 % interval's coverage.

    python3 bench/inflight_band.py [--units 60] [--mean-life 200] [--scatter 0.1]
                                   [--tracker 0.01] [--bit-grease shared] [--seed N]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.seeds import master
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.reasoner.inflight.baseline import Baseline
from mapr_daemon.reasoner.prognosis.fusion import fit_rul_fused, observation
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

MODEL = Path(__file__).resolve().parents[1] / "mapr_daemon" / "testbed" / "models" / \
    "prognosis-aileron-uav-2000hz.npz"
Z90 = 1.645


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--units", type=int, default=60)
    ap.add_argument("--mean-life", type=float, default=200.0)
    ap.add_argument("--scatter", type=float, default=0.1)
    ap.add_argument("--tracker", type=float, default=0.01)
    ap.add_argument("--bit-grease", choices=("shared", "independent"), default="shared")
    ap.add_argument("--seed", type=int, default=None)
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/inflight_band.py --units {args.units} "
                             f"--mean-life {args.mean_life:g} --scatter {args.scatter:g} "
                             f"--tracker {args.tracker:g} --bit-grease {args.bit_grease}")
    t0, c0 = time.time(), time.process_time()
    model = PrognosticModel.load(str(MODEL))
    noise, prior = model.noise["friction"], model.priors["friction"]
    rng = np.random.default_rng(seed)
    s = FAILURE["friction"] - 1.0
    err, stated = [], []
    res: dict[tuple[str, float], list[tuple[bool, bool]]] = {}
    for u in range(args.units):
        life = args.mean_life * rng.uniform(0.7, 1.3)
        n = np.arange(int(life) + 2)
        path = 1.0 + s * (n / life) ** 1.5
        grease = np.exp(args.scatter * rng.standard_normal(n.size))
        bit_grease = grease if args.bit_grease == "shared" else \
            np.exp(args.scatter * rng.standard_normal(n.size))
        h_bit = (path * bit_grease - 1.0) / s
        est = noise.offset + noise.gain * h_bit + \
            (noise.sd0 + noise.sd1 * np.clip(h_bit, 0.0, 1.5)) * rng.standard_normal(n.size)
        if noise.floor is not None:
            est = np.maximum(est, noise.floor)
        offset = rng.lognormal(0.0, 0.2)
        base = Baseline()
        rows = []
        for k in n:
            v = offset * path[k] * grease[k] * (1.0 + args.tracker * rng.standard_normal())
            r = base.rebase({"friction": {"value": v, "sd": args.tracker * v}},
                            int(k) + 1)["friction"]
            o = observation("friction", r)
            if o is None:
                continue
            rows.append((float(k), *o[1:]))
            err.append(o[1] - (path[k] - 1.0) / s)
            stated.append(float(r["sd_change"]) / s)
        for lam in (0.5, 0.75):
            now = int(lam * life)
            truth = life - now
            fl = np.arange(0, now + 1, dtype=np.float64)
            obs = [o for o in rows if o[0] <= now]
            ways = (("BITs only", []), ("BITs + in-flight", obs),
                    ("  (in-flight as independent)",
                     [(o[0], o[1], math.hypot(o[2], o[3])) for o in obs]))
            for name, extra in ways:
                r = fit_rul_fused(fl, est[: now + 1], float(now), "friction", noise, prior,
                                  extra, seed=u)
                mid = r.rul if math.isfinite(r.rul) else 1e9
                res.setdefault((name, lam), []).append(
                    (abs(mid - truth) <= 0.2 * truth, r.lower <= truth <= r.upper))
    e, d = np.array(err), np.array(stated)
    print(f"per flight ({e.size} flights of {args.units} units; in failure thresholds): "
          f"error mean {e.mean():+.3f} sd {e.std():.3f} worst {np.abs(e).max():.3f}; stated "
          f"sd mean {d.mean():.3f}; error sd / stated sd {e.std() / d.mean():.2f}; rms "
          f"error/stated {math.sqrt(float(np.mean((e / d) ** 2))):.2f}; stated 90 % band "
          f"holds the path in {100 * np.mean(np.abs(e) <= Z90 * d):.1f} %")
    print(f"RUL, PBIT every flight (BIT grease {args.bit_grease}), alpha 0.2:")
    for (name, lam), v in res.items():
        a = np.array(v, dtype=np.float64)
        print(f"  lambda {lam:.2f} {name:<30} alpha-lambda {a[:, 0].mean():4.0%}, 90 % "
              f"interval covers {a[:, 1].mean():4.0%} ({a.shape[0]} units)")
    print(f"wall {time.time() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
