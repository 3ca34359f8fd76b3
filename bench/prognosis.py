"""RUL along run-to-failure trajectories: alpha-lambda, relative accuracy on RUL, horizon.

Two units of each aging kind of issue 5 (capacitance, ESR, SMPS high/low-side Ron, inverter
phase-A Ron, friction), a BIT every 4 flights of each unit's life. Each BIT is read by the
kind's degradation estimator (mapr_daemon/reasoner/prognosis/wear_estimators.py), trained on BITs
flown at known
degradations with seeds of their own; its scale error and noise are measured on calibration
BITs of yet other seeds. At each BIT from a quarter of the life on, the reasoner fits the
kind's aging shape (exponential, reciprocal, power; see mapr_daemon/reasoner/prognosis/trend.py) to
the
estimates so far, with a fleet prior (shape parameter jointly with the life, and the part's
flight-to-flight scatter) learned from 30 other units per kind, and again without it, from
the same BITs. alpha = 0.2 at lambda 0.5 and 0.75 (t0 = flight 0), beta = 0.5; relative
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
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training.dictionary_build import build
from mapr_daemon.reasoner.training.rul_scoring import (
    CALIBRATION_LEVELS,
    CALIBRATION_REPS,
    FLEET_UNITS,
    TRAINING_BITS,
    Scored,
    observe_units,
    score,
)

RESOLVES_SD = 0.25
"""Per-BIT noise sd (in units of the threshold) above which a kind's threshold is not resolved:
its RUL cannot be placed within 20 % from a few dozen BITs."""
KINDS = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction")


def _flights(x: float) -> str:
    """A RUL figure; ``inf`` (the trend never reaches the threshold) printed as such."""
    return f"{x:.1f}" if math.isfinite(x) else "beyond horizon"


def _table(scored: list[Scored]) -> None:
    print(f"{'unit':>24} {'EoL':>6} {'al@0.5':>7} {'al@0.75':>7} {'RA@0.5':>7} {'RA@0.75':>7}"
          f" {'PH':>6}  RUL at lambda 0.75 (true / est [5 %, 95 %])")
    passes: list[bool] = []
    ras: list[float] = []
    for s in scored:
        passes += list(s.alpha_lambda.values())
        ras += [v for v in s.relative_accuracy.values() if not math.isnan(v)]
        head = (f"{s.kind + ':' + str(s.seed):>24} {s.eol:6.1f} {s.alpha_lambda[0.5]!s:>7}"
                f" {s.alpha_lambda[0.75]!s:>7} {s.relative_accuracy[0.5]:7.2f}"
                f" {s.relative_accuracy[0.75]:7.2f} {s.horizon:6.1f}  ")
        if s.times.size == 0:
            print(head + "no prediction: unobservable")
            continue
        k = int(np.argmin(np.abs(s.times - 0.75 * s.eol)))
        print(head + f"{s.true_rul[k]:.1f} / {_flights(s.est_rul[k])} [{_flights(s.lower[k])},"
              f" {_flights(s.upper[k])}]")
    rate = 100 * sum(passes) / len(passes)
    print(f"alpha-lambda pass {rate:.1f} % ({sum(passes)}/{len(passes)}), target >= 90 %: "
          f"{'met' if rate >= 90 else 'MISSED'}; median RA on RUL {np.median(ras):.2f} "
          f"(over {len(ras)} predictions)")
    horizons = [s.horizon for s in scored]
    print(f"prognostic horizon (flights): median {np.median(horizons):.1f}, "
          f"units with PH > 0: {sum(h > 0 for h in horizons)}/{len(horizons)}")
    blind = sorted({s.kind for s in scored if not _resolves(s)})
    if blind:
        seen = [v for s in scored if _resolves(s) for v in s.alpha_lambda.values()]
        print(f"without the kinds whose per-BIT estimate cannot resolve the threshold "
              f"(calibrated noise sd at h = 1 above {RESOLVES_SD}; {', '.join(blind)}): "
              f"alpha-lambda pass {100 * sum(seen) / max(len(seen), 1):.1f} % "
              f"({sum(seen)}/{len(seen)})")


def _resolves(s: Scored) -> bool:
    """Whether the kind's calibrated per-BIT noise at the threshold leaves a trend a chance."""
    return s.noise is not None and float(s.noise.sd(np.array(1.0))) <= RESOLVES_SD


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", type=Path)
    ap.add_argument("--units", type=int, default=2, help="units per kind")
    ap.add_argument("--bit-every", type=int, default=4, help="flights between BITs")
    args = ap.parse_args()
    start = time.monotonic()
    params = load_actuator(default_actuator_path())
    root = Path(__file__).resolve().parents[1]
    d = (Dictionary.load(args.dictionary) if args.dictionary else
         build(params, DictionarySpec.load(root / "configs/reasoner/dictionary.yaml")))
    units = [(k, s) for k in KINDS for s in range(1, args.units + 1)]
    observed = observe_units(d, params, units, bit_every=args.bit_every)
    print(f"BIT every {args.bit_every} flights, {sum(o.flights.size for o in observed)} unit "
          f"BITs; per kind: {TRAINING_BITS} estimator training BITs, "
          f"{CALIBRATION_REPS * len(CALIBRATION_LEVELS)} calibration BITs, fleet prior from "
          f"{FLEET_UNITS} units; per-BIT estimate measured on the calibration BITs:")
    for kind in KINDS:
        o = next(o for o in observed if o.kind == kind)
        n = o.noise
        print(f"  {kind:>20}: " + (f"estimate = {n.offset:.3f} + {n.gain:.3f} h, noise sd "
                                   f"{n.sd0:.3f} + {n.sd1:.3f} h" if n is not None else
                                   f"UNOBSERVABLE ({o.unobservable})"))
    for use_prior in (True, False):
        print(f"\n== fleet prior on the aging shape: {'yes' if use_prior else 'no'} ==")
        _table(score(observed, params, use_prior))
    print(f"total runtime {time.monotonic() - start:.1f} s, load average "
          f"{os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
