"""RUL along run-to-failure trajectories: alpha-lambda, relative accuracy on RUL, horizon.

Two units of each aging kind of issue 5 (capacitance, ESR, SMPS high/low-side Ron, inverter
phase-A Ron, friction), a BIT on 16 flights spread over each unit's life; the reasoner trends
its per-BIT estimate of the component (quadratic least squares, 5-95 % bounds from the fit's
covariance). alpha = 0.2 at lambda 0.5 and 0.75 (t0 = flight 0), beta = 0.5. Target: alpha-lambda
pass >= 90 %. Run:  python3 bench/prognosis.py --dictionary dictionary.npz  (builds one if absent).
"""

from __future__ import annotations

import argparse
import math
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
    ap.add_argument("--points", type=int, default=16, help="BIT flights per unit")
    args = ap.parse_args()
    start = time.monotonic()
    params = load_actuator(default_actuator_path())
    root = Path(__file__).resolve().parents[1]
    d = (Dictionary.load(args.dictionary) if args.dictionary else
         build(params, DictionarySpec.load(root / "configs/reasoner/dictionary.yaml")))
    units = [(k, s) for k in KINDS for s in range(1, args.units + 1)]
    scored = score_units(d, params, units, n_points=args.points)
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
    print(f"total runtime {time.monotonic() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
