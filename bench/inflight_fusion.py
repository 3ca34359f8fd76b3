"""Friction's RUL from BITs alone against BITs + per-flight in-flight estimates (issue 29).

In memory (no plant): run-to-failure friction paths (:func:`mapr_daemon.ema.degradation.
trajectory`, lives 200 +/- 30 %); each BIT's raw friction estimate drawn from the demo
prognostic model's *measured* per-BIT noise (``offset + gain*h + (sd0 + sd1*h)*e``, its
floor applied), each flight's in-flight change drawn from the tracker's *measured* error
(docs/reasoner.md: twin units rms 0.006 of the failure threshold with stated sd 0.023;
mismatched units rms 0.14, stated sd 0.046) against that flight's friction, which is the
aging path times the flight's grease scatter (lognormal, sd 0.1: the plant's), from flight
4 on (flights 1-3 commission the
baseline). At 50 % and 75 % of each unit's life the trend (the demo model's fleet prior)
gives a RUL: alpha-lambda (alpha 0.2) and 90 % interval coverage, PBIT every flight and
every 4 flights.

    python3 bench/inflight_fusion.py --units 40
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
from mapr_daemon.ema.degradation import FAILURE, trajectory
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.prognosis.fusion import fit_rul_fused
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

MODEL = Path(__file__).resolve().parents[1] / "mapr_daemon" / "testbed" / "models" / \
    "prognosis-aileron-uav-2000hz.npz"
ERRORS = {"twin": (0.006, 0.023), "mismatched": (0.14, 0.046)}
"""In-flight change error rms and stated sd, in failure thresholds (docs/reasoner.md)."""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--units", type=int, default=40)
    ap.add_argument("--seed", type=int, default=None)
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/inflight_fusion.py --units {args.units}")
    t0, c0 = time.time(), time.process_time()
    model = PrognosticModel.load(str(MODEL))
    noise, prior = model.noise["friction"], model.priors["friction"]
    params = load_actuator(default_actuator_path())
    rng = np.random.default_rng(seed)
    scale = FAILURE["friction"] - 1.0
    rows: dict[tuple[str, int, str], list[tuple[bool, bool, float]]] = {}
    for u in range(args.units):
        t = trajectory(params, "friction", 400, seed=int(rng.integers(2**31)))
        h_path = (t.values / t.nominal - 1.0) / scale
        for lam in (0.5, 0.75):
            now = int(lam * t.eol_flight)
            true_rul = t.eol_flight - now
            for every in (1, 4):
                fl = np.arange(0, now + 1, every, dtype=np.float64)
                h = h_path[fl.astype(int)]
                est = noise.offset + noise.gain * h + (noise.sd0 + noise.sd1 * h) * \
                    rng.standard_normal(fl.size)
                if noise.floor is not None:
                    est = np.maximum(est, noise.floor)
                for scen, (err, stated) in ERRORS.items():
                    n_in = np.arange(4, now + 1, dtype=np.float64)
                    # the flight's own friction: the path times its grease scatter
                    # (lognormal, the actuator file's friction_flight_sd), then the tracker's
                    # error against that flight's friction
                    ratio = (1.0 + scale * h_path[n_in.astype(int)]) * np.exp(
                        params.motor.friction_flight_sd * rng.standard_normal(n_in.size))
                    seen = (ratio - 1.0) / scale + err * rng.standard_normal(n_in.size)
                    obs = [(float(n), float(v), stated) for n, v in zip(n_in, seen,
                                                                        strict=True)]
                    for mode, extra in (("bits", []), ("bits+inflight", obs)):
                        if mode == "bits" and scen != "twin":
                            continue
                        r = fit_rul_fused(fl, est, float(now), "friction", noise, prior,
                                          extra, seed=u)
                        mid = r.rul if math.isfinite(r.rul) else 1e9
                        ok = abs(mid - true_rul) <= 0.2 * true_rul
                        cov = r.lower <= true_rul <= r.upper
                        key = (mode if mode == "bits" else f"{mode} ({scen})", every,
                               f"{lam:.2f}")
                        rows.setdefault(key, []).append(
                            (ok, cov, abs(mid - true_rul) / true_rul))
    for (mode, every, at), v in sorted(rows.items()):
        a = np.array(v, dtype=np.float64)
        print(f"PBIT every {every} flight(s), lambda {at}, {mode}: alpha-lambda(0.2) "
              f"{a[:, 0].mean():.0%}, 90 % interval covers {a[:, 1].mean():.0%}, |error| "
              f"mean {a[:, 2].mean():.2f} worst {a[:, 2].max():.2f} of the true RUL "
              f"({a.shape[0]} units)")
    print(f"wall {time.time() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
