"""Is each BIT's stated noise the noise it has? The prognostic model's per-BIT sd, checked on
fresh BITs over the envelope and at nominal conditions.

    python3 bench/estimate_noise.py --dictionary D.npz --prognosis P.npz [--bits 150] [--seed N]

Per trended kind, ``--bits`` BITs at degradations uniform in 0-1.2 of the failure threshold,
flown by the EMA model (:func:`~mapr_daemon.reasoner.training.corpus.simulate_bit` batches) at seeds
drawn fresh from the printed run seed, clear of the model's training (7,000,000 up) and
calibration (8,000,000 up) seeds; two sets: **envelope** (pressure up to the envelope's
maximum with a fifth on the ground, ambient temperature and aircraft-bus voltage uniform over
their ranges, as the model was built) and **nominal** (the five named flight conditions'
pressures, nominal temperature and bus). Each BIT's estimate is read by the model two ways:
envelope-wide (one line ``(estimate - offset) / gain``, sd ``sd0 + sd1*h``: what the product
did before) and at the BIT's condition (:meth:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise
.calibrate` and ``h_sd``: what it does now). Printed per kind and part of the envelope (bus
below nominal - 2 V, the rest, nominal), per reading: the error's mean and sd against the
truth, the median stated sd and how often the truth lies inside the 90 % band (90 % if
calibrated). The part furthest from 90 % is printed beside the range.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from seeds import fresh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import wear_estimators
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.training.corpus import BitRuns
from mapr_daemon.reasoner.training.dictionary_build import stream_matrices
from mapr_daemon.reasoner.training.prognosis_build import conditions, fault_at

NAMED_PRESSURES = (0.0, 300.0, 600.0, 1000.0, 1500.0)
Z90 = 1.645
SEED_BASE = 2_000_000_000


def fly(d: Dictionary, model: PrognosticModel, kinds: list[str], n: int, envelope: bool,
        rng: np.random.Generator) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per kind: (truth h, raw estimate, scaled condition rows) of ``n`` fresh BITs."""
    params = load_actuator(default_actuator_path())
    todo = [(k, float(h)) for k in kinds for h in rng.uniform(0.0, 1.2, n)]
    q, amb, bus = conditions(params, len(todo), rng, envelope)
    if not envelope:
        q = [float(v) for v in rng.choice(NAMED_PRESSURES, len(todo))]
    seeds = [int(s) for s in rng.integers(SEED_BASE, 2 * SEED_BASE, len(todo))]
    runs = BitRuns.of([fault_at(params, k, h) for k, h in todo], q, seeds, amb, bus)
    m = stream_matrices(params, runs, d.window_starts, d.window_samples)
    y, c = wear_estimators.observations(d, m, q)
    out = {}
    for k in kinds:
        rows = [i for i, (kk, _) in enumerate(todo) if kk == k]
        est = np.array([model.estimators[k].estimate(y[i], c[i]) for i in rows])
        out[k] = (np.array([todo[i][1] for i in rows]), est, c[rows])
    return out


def line(label: str, h: np.ndarray, flat: tuple[np.ndarray, np.ndarray],
         cond: tuple[np.ndarray, np.ndarray]) -> str:
    """One part: per reading (envelope-wide line and sd; at the BIT's condition) the error's
    mean and sd, the stated sd and the share of BITs inside the 90 % band."""
    if h.size == 0:
        return f"    {label:<22} no BITs"
    parts = []
    for name, (reading, sd) in (("envelope-wide", flat), ("at the BIT's condition", cond)):
        err = reading - h
        parts.append(f"{name}: error {err.mean():+.3f} sd {err.std():.3f}, stated "
                     f"{np.median(sd):.3f}, in 90 % band "
                     f"{100 * np.mean(np.abs(err) <= Z90 * sd):>3.0f} %")
    return f"    {label:<22} {h.size:>4} BITs  " + "  |  ".join(parts)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", type=Path, required=True)
    ap.add_argument("--prognosis", type=Path, required=True)
    ap.add_argument("--bits", type=int, default=150, help="BITs per kind and set")
    ap.add_argument("--seed", type=int)
    args = ap.parse_args()
    seed = fresh(args.seed)
    started, cpu = time.monotonic(), time.process_time()
    d = Dictionary.load(args.dictionary)
    model = PrognosticModel.load(args.prognosis)
    kinds = list(model.kinds)
    print(f"prognostic model {args.prognosis}: trends {', '.join(kinds)}; not trended: "
          + ("; ".join(f"{k} ({why})" for k, why in model.unobservable.items()) or "none"))
    rng = np.random.default_rng(seed)
    worst: dict[str, float] = {}
    for name, envelope in (("envelope", True), ("nominal", False)):
        sets = fly(d, model, kinds, args.bits, envelope, rng)
        print(f"\n== {name}: {args.bits} BITs per kind, degradation 0-1.2 of the threshold "
              "(errors and sd in units of the threshold) ==")
        for k in kinds:
            h, est, c = sets[k]
            noise = model.noise[k]
            truth = np.clip(h, 0.0, None)
            flat = (noise.calibrate(est), noise.h_sd(truth))
            cond = (noise.calibrate(est, c), noise.h_sd(truth, c))
            print(f"  {k}")
            parts = [("all", np.ones(h.size, dtype=bool))]
            if envelope:
                parts += [("bus below nominal-2 V", c[:, 1] < -2.0),
                          ("bus within 2 V", c[:, 1] >= -2.0)]
            for label, sel in parts:
                print(line(label, h[sel], (flat[0][sel], flat[1][sel]),
                           (cond[0][sel], cond[1][sel])))
                if sel.any():
                    worst[f"{k}, {name}, {label}"] = 100 * float(np.mean(
                        np.abs(cond[0][sel] - h[sel]) <= Z90 * cond[1][sel]))
    far = max(worst.items(), key=lambda kv: abs(kv[1] - 90.0))
    print(f"\nat the BIT's condition, 90 % bands cover {min(worst.values()):.0f}-"
          f"{max(worst.values()):.0f} % over the {len(worst)} parts above; furthest from 90 %: "
          f"{far[0]} ({far[1]:.0f} %)")
    print(f"total {time.monotonic() - started:.0f} s wall, {time.process_time() - cpu:.0f} s "
          f"CPU, load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
