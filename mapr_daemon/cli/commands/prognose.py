"""``mapr prognose``: score RUL along a run-to-failure trajectory.

TRAJECTORY is ``KIND:SEED`` — one unit of issue 5's aging model (``esr:3``, ``friction:1``,
...) with its true end of life. A BIT is flown every ``--bit-every`` flights of its life,
together with the kind's estimator training BITs and calibration BITs (seeds of their own);
each BIT is read by the kind's degradation estimator, and the reasoner fits the component's
aging shape to the estimates and predicts RUL with 5/50/95 % bounds (docs/reasoner.md, 'SoH
and RUL')::

    mapr prognose friction:1 --dictionary dictionary.npz

Prints one JSON object: per BIT flight the true and estimated degradation, per prediction the
true and estimated RUL with bounds, alpha-lambda (alpha 0.2 at lambda 0.5 and 0.75), relative
accuracy on RUL and the prognostic horizon. A RUL or bound the trend does not reach within
its horizon is ``null``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("prognose", help="score RUL along a run-to-failure trajectory",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trajectory", help="KIND:SEED, e.g. friction:1")
    p.add_argument("--dictionary", required=True, type=Path)
    p.add_argument("--actuator", type=Path, help="actuator YAML (default: aileron-uav)")
    p.add_argument("--bit-every", type=int, default=4, help="flights between BITs")
    p.add_argument("--no-prior", action="store_true",
                   help="no fleet prior on the aging shape (the unit's BITs alone)")
    p.set_defaults(func=run)


def _num(x: float) -> float | None:
    """A finite figure, or ``null``: a RUL bound beyond the horizon (never ``nan``)."""
    return None if not math.isfinite(x) else round(float(x), 3)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.rul_scoring import score_units

    kind, sep, seed = args.trajectory.partition(":")
    try:
        unit = int(seed) if sep else 0
    except ValueError:
        raise ConfigError(f"bad unit seed {seed!r}", field="trajectory") from None
    d = Dictionary.load(args.dictionary)
    params = load_actuator(args.actuator or default_actuator_path())
    (s,) = score_units(d, params, [(kind, unit)], bit_every=args.bit_every,
                       use_prior=not args.no_prior)
    print(json.dumps({
        "kind": s.kind, "seed": s.seed, "eol_flight": round(s.eol, 2),
        "flights": s.flights.tolist(), "degradation_true": [_num(x) for x in s.h_true],
        "degradation_est": [_num(x) for x in s.h_est],
        "predictions": [{"flight": float(t), "rul_true": _num(r), "rul": _num(e),
                         "lower": _num(lo), "upper": _num(hi)}
                        for t, r, e, lo, hi in zip(s.times, s.true_rul, s.est_rul, s.lower,
                                                   s.upper, strict=True)],
        "alpha_lambda": {str(k): v for k, v in s.alpha_lambda.items()},
        "relative_accuracy": {str(k): _num(v) for k, v in s.relative_accuracy.items()},
        "prognostic_horizon_flights": _num(s.horizon),
        "noise": None if s.noise is None else dataclasses.asdict(s.noise),
        "unobservable": s.unobservable,
        "prior": None if s.prior is None else dataclasses.asdict(s.prior),
    }))
    return 0
