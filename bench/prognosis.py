"""RUL along run-to-failure trajectories: alpha-lambda, relative accuracy on RUL, horizon.

Two units of each aging kind of issue 5 (capacitance, ESR, SMPS high/low-side Ron, inverter
phase-A Ron, friction), a BIT every 4 flights of each unit's life; at each BIT from a quarter
of the life on, the reasoner fits the kind's aging shape (exponential, reciprocal, power; see
mapr_daemon/reasoner/trend.py) to its per-BIT estimates of the component with their measured
noise, and a fleet prior on the shape parameter learned from 8 other units per kind
(``--no-prior``: none). alpha = 0.2 at lambda 0.5 and 0.75 (t0 = flight 0), beta = 0.5; relative
accuracy on RUL; prognostic horizon. Target: alpha-lambda pass >= 90 %.
Run:  python3 bench/prognosis.py --dictionary dictionary.npz  (builds one if absent).
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

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.build import build
from mapr_daemon.reasoner.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.trajectory import score_units

KINDS = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction")


def _flights(x: float) -> str:
    """A RUL figure; ``inf`` (the trend never reaches the threshold) printed as such."""
    return f"{x:.1f}" if math.isfinite(x) else "beyond horizon"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", type=Path)
    ap.add_argument("--units", type=int, default=2, help="units per kind")
    ap.add_argument("--bit-every", type=int, default=4, help="flights between BITs")
    ap.add_argument("--no-prior", action="store_true", help="no fleet prior on the shape")
    args = ap.parse_args()
    start = time.monotonic()
    params = load_actuator(default_actuator_path())
    root = Path(__file__).resolve().parents[1]
    d = (Dictionary.load(args.dictionary) if args.dictionary else
         build(params, DictionarySpec.load(root / "configs/reasoner/dictionary.yaml")))
    units = [(k, s) for k in KINDS for s in range(1, args.units + 1)]
    scored = score_units(d, params, units, bit_every=args.bit_every,
                         use_prior=not args.no_prior)
    print(f"BIT every {args.bit_every} flights; fleet prior: {'no' if args.no_prior else 'yes'}")
    for kind in KINDS:
        s0 = next(s for s in scored if s.kind == kind)
        print(f"  {kind:>20}: per-BIT estimate = {s0.noise.offset:.3f} + {s0.noise.gain:.3f} h,"
              f" noise sd {s0.noise.sd0:.3f} + {s0.noise.sd1:.3f} h")
    print(f"{'unit':>24} {'EoL':>6} {'al@0.5':>7} {'al@0.75':>7} {'RA@0.5':>7} {'RA@0.75':>7}"
          f" {'PH':>6}  RUL at lambda 0.75 (true / est [5 %, 95 %])")
    passes = []
    ras = []
    for s in scored:
        k = int(np.argmin(np.abs(s.times - 0.75 * s.eol)))
        passes += list(s.alpha_lambda.values())
        ras += [v for v in s.relative_accuracy.values() if math.isfinite(v)]
        print(f"{s.kind + ':' + str(s.seed):>24} {s.eol:6.1f} {s.alpha_lambda[0.5]!s:>7}"
              f" {s.alpha_lambda[0.75]!s:>7} {s.relative_accuracy[0.5]:7.2f}"
              f" {s.relative_accuracy[0.75]:7.2f} {s.horizon:6.1f}  {s.true_rul[k]:.1f} /"
              f" {_flights(s.est_rul[k])} [{_flights(s.lower[k])}, {_flights(s.upper[k])}]")
    rate = 100 * sum(passes) / len(passes)
    print(f"alpha-lambda pass {rate:.1f} % ({sum(passes)}/{len(passes)}), target >= 90 %: "
          f"{'met' if rate >= 90 else 'MISSED'}; median RA on RUL {np.median(ras):.2f}")
    horizons = [s.horizon for s in scored]
    print(f"prognostic horizon (flights): median {np.median(horizons):.1f}, "
          f"units with PH > 0: {sum(h > 0 for h in horizons)}/{len(horizons)}")
    print(f"total runtime {time.monotonic() - start:.1f} s, load average "
          f"{os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
