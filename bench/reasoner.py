"""Real-time factor of the whole reasoner per actuator: features + classifier + EKF.

The dictionary is the full one the daemon loads (``--dictionary``) or a small one built here
(ESR and friction templates, the test suite's spec); then every held-out BIT record (healthy
and faulted, cruise pressure) goes through ``Reasoner.diagnose`` one at a time, as the daemon
calls it for one actuator.
Real-time factor = seconds of bus data / wall seconds spent in ``diagnose`` (best of
``--repeat``); the thread's CPU time is printed beside it, because on a shared machine other
processes stretch the wall clock. The EKF's own share is timed separately. The first record
is decided once before timing, so the compiled kernels' one-off load is not counted.
Target: >= 50x real time (issue 6).

Run: ``python3 bench/reasoner.py [--dictionary dictionary.npz]`` (the full dictionary the daemon
loads; without it a small one is built). Figures are of this machine; the load average is printed.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.ekf.estimator import ParameterEstimator
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import simulate_bit

SPEC = DictionarySpec(
    pressures_pa=(0.0, 800.0, 1600.0), nominal_per_pressure=4, severities=(0.25, 0.5, 0.75, 1.0),
    kinds=("esr", "friction"), shorts=("A_high",), opens=("A_high",), seeds_per_point=2,
    healthy_runs=60, calibration_runs=12, record_pool=3, calibration_pressure_pa=(200.0, 1400.0),
    threshold_margin=1.5, subspace_dims=8, knots=(0.0, 0.5, 1.0))
"""The test suite's small dictionary (tests/reasoner/conftest.py): the per-record cost of the
classifier grows with the number of templates; the EKF's does not."""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=8, help="held-out BIT records")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dictionary", type=Path,
                    help="a full dictionary (mapr dictionary build); default: a small one")
    args = ap.parse_args()
    params = load_actuator(default_actuator_path())
    t0 = time.perf_counter()
    d = Dictionary.load(args.dictionary) if args.dictionary else \
        dictionary_build.build(params, SPEC)
    print(f"dictionary: {args.dictionary or 'small (the test suite spec)'}, "
          f"{len(d.templates)} templates")
    kinds = [FaultSet()] + [FaultSet.of([at_severity(params, k, s)])
                            for k in ("esr", "friction") for s in (0.4, 0.8)]
    held_fs = [kinds[i % len(kinds)] for i in range(args.records)]
    held = simulate_bit(params, held_fs, [1600.0] * args.records,
                        [70_000 + i for i in range(args.records)])
    setup = time.perf_counter() - t0
    reasoner = Reasoner(d, params)
    record_s = held.command_deg.size / held.sample_rate_hz
    best_all = best_ekf = cpu_all = cpu_ekf = float("inf")
    first = {k: v[0] for k, v in held.channels.items()}
    reasoner.diagnose(first, held.command_deg, float(held.dynamic_pressure_pa[0]))  # warm-up
    for _ in range(args.repeat):
        t, c = time.perf_counter(), time.thread_time()
        for i in range(held.n):
            ch = {k: v[i] for k, v in held.channels.items()}
            reasoner.diagnose(ch, held.command_deg, float(held.dynamic_pressure_pa[i]))
        best_all = min(best_all, (time.perf_counter() - t) / held.n)
        cpu_all = min(cpu_all, (time.thread_time() - c) / held.n)
        t, c = time.perf_counter(), time.thread_time()
        for i in range(held.n):
            ch = {k: v[i] for k, v in held.channels.items()}
            ParameterEstimator(params).run(ch, float(held.dynamic_pressure_pa[i]))
        best_ekf = min(best_ekf, (time.perf_counter() - t) / held.n)
        cpu_ekf = min(cpu_ekf, (time.thread_time() - c) / held.n)
    load = os.getloadavg()[0]
    print(f"setup (dictionary + {held.n} held-out records simulated): {setup:.1f} s")
    print(f"record {record_s:.2f} s of bus data at {held.sample_rate_hz:g} Hz; "
          f"best of {args.repeat}, load average {load:.2f}")
    print(f"whole reasoner (features + classifier + EKF): {best_all * 1e3:.1f} ms per record, "
          f"real-time factor {record_s / best_all:.0f}x per actuator (target >= 50x: "
          f"{'met' if record_s / best_all >= 50 else 'MISSED'}); by thread CPU time "
          f"{cpu_all * 1e3:.1f} ms, {record_s / cpu_all:.0f}x")
    print(f"EKF alone: {best_ekf * 1e3:.1f} ms per record, {record_s / best_ekf:.0f}x real time; "
          f"by thread CPU time {cpu_ekf * 1e3:.1f} ms, {record_s / cpu_ekf:.0f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
