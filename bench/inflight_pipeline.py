"""The cost of in-flight tracking in the pipeline, per actuator, on whole flights (issue 29).

Whole flights (255 s at ``--scale 1``, :mod:`mapr_daemon.testbed.whole_flight`) of healthy
units, each handed to the actuator's :class:`~mapr_daemon.pipeline.inflight.InflightWatch`
as decoded series in 2 s batches with a BIT request every 60 s
(:mod:`mapr_daemon.testbed.flight_series`): what a fleet worker or the daemon adds per
recording with ``reasoner.inflight`` on, from the decoded series to the stored row
(aligning the channels, cutting out the BITs, the accumulator, the tracker, the baseline).
Prints per flight the thread CPU time and the real-time factor (bus seconds per CPU
second), mean and worst, and the worker's combined rate with the decode-and-BIT path's
own measured rate (docs/fleet.md: 362-454x real time on whole-flight recordings, one task
in one process), ``1 / (1/a + 1/b)``.

    python3 bench/inflight_pipeline.py --flights 6
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.seeds import master
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.pipeline.bitcut import BitCutter
from mapr_daemon.pipeline.inflight import InflightWatch
from mapr_daemon.testbed.flight_series import flight_series
from mapr_daemon.testbed.whole_flight import flight_profile, fly

DECODE_X = (362.0, 454.0)
"""The worker's decode-and-BIT rate on whole-flight recordings (docs/fleet.md)."""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--flights", type=int, default=6)
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=None)
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/inflight_pipeline.py --flights {args.flights} "
                             f"--scale {args.scale:g}")
    t0, c0 = time.time(), time.process_time()
    params = load_actuator(default_actuator_path())
    rate = params.sensors.sample_rate_hz
    rng = np.random.default_rng(seed)
    watch = InflightWatch("EMA1", params, BitCutter(params.bit, rate))
    factors, cpus = [], []
    for k in range(args.flights):
        prof = flight_profile(rate, seed=int(rng.integers(2**31)), scale=args.scale)
        flown = fly([RunSpec(params, seed=int(rng.integers(2**31)))], prof)
        span = prof.n_samples / rate
        batches = flight_series(flown.channels[0], prof.dynamic_pressure_pa, rate,
                                int(1e12) * (k + 1), np.arange(30.0, span - 5.0, 60.0).tolist())
        watch.flight = k + 1
        c = time.thread_time()
        for b in batches:
            watch.feed(b)
        row = watch.finish("BENCH")
        cpu = time.thread_time() - c
        cpus.append(cpu)
        factors.append(span / cpu)
        print(f"flight {k + 1}: {span:.0f} s of bus, {cpu * 1e3:.0f} ms CPU = {span / cpu:.0f}x "
              f"real time; filtered {0 if row is None else row.filtered_s:.0f} s")
    f = np.array(factors)
    print(f"in-flight path per actuator: real-time factor mean {f.mean():.0f}x, worst "
          f"{f.min():.0f}x; CPU per flight mean {np.mean(cpus) * 1e3:.0f} ms, worst "
          f"{max(cpus) * 1e3:.0f} ms")
    for d in DECODE_X:
        print(f"with the decode-and-BIT path at {d:.0f}x: worker {1 / (1 / d + 1 / f.mean()):.0f}x "
              f"mean, {1 / (1 / d + 1 / f.min()):.0f}x worst (target >= 100x)")
    print(f"wall {time.time() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
