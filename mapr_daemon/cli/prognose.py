"""``mapr prognose``: score RUL along a run-to-failure trajectory.

TRAJECTORY is ``KIND:SEED`` — one unit of issue 5's aging model (``esr:3``, ``friction:1``,
...) with its true end of life. A BIT is flown on ``--points`` flights spread over the life;
the reasoner trends its estimate of the component and predicts RUL with 5-95 % bounds::

    mapr prognose friction:1 --dictionary dictionary.npz

Prints one JSON object: per BIT flight the true and estimated degradation, per prediction the
true and estimated RUL with bounds, alpha-lambda (alpha 0.2 at lambda 0.5 and 0.75), relative
accuracy on RUL and the prognostic horizon. A RUL or bound the trend does not reach within
its horizon is ``null``.
"""

from __future__ import annotations

import argparse
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
    p.add_argument("--points", type=int, default=24, help="BIT flights over the life")
    p.set_defaults(func=run)


def _num(x: float) -> float | None:
    """A finite figure, or ``null``: a RUL bound beyond the horizon (never ``nan``)."""
    return None if not math.isfinite(x) else round(float(x), 3)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.dictionary import Dictionary
    from mapr_daemon.reasoner.trajectory import score_units

    kind, sep, seed = args.trajectory.partition(":")
    try:
        unit = int(seed) if sep else 0
    except ValueError:
        raise ConfigError(f"bad unit seed {seed!r}", field="trajectory") from None
    d = Dictionary.load(args.dictionary)
    params = load_actuator(args.actuator or default_actuator_path())
    (s,) = score_units(d, params, [(kind, unit)], n_points=args.points)
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
    }))
    return 0
