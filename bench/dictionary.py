"""Dictionary build: wall time, CPU time, peak memory, with every usable core and with one.

Four cases, each in a fresh Python process (peak RSS is a process's high-water mark, so two
builds in one process would hide the second's):

* ``default``: the shipped spec (``configs/reasoner/dictionary.yaml``, seed_base 0: runs
  seeded 0..1495) through ``build()`` with a thread per usable core, then with one worker;
* ``demo``: ``mapr demo`` on a fresh cache (its first run: the flight, the bus, then the
  dictionary build and the diagnosis; demo seed 1), once with the process's usual cores and
  once pinned to one core (CPU affinity), where the build's default worker count is 1.

Each process loads the compiled kernels first (timed apart: ``warm-up``); a case's wall and
CPU time (user + system of the whole process, all threads) start after it, its peak RSS is the
whole process's (the default case's also as it stood when the last BIT was flown). CPU/wall
near the worker count says both cores were busy. The machine is shared: the load average is
printed before and after each case, nothing is asserted.
Run: ``python3 bench/dictionary.py`` (``--only default`` or ``--only demo``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

LIMIT_MB = 1024.0
"""The memory a build must stay under (issue 14: <= 1 GB)."""


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _warm() -> float:
    """Load (or compile) the plant kernel; seconds taken."""
    from mapr_daemon.ema.faults import FaultSet
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.training.corpus import simulate_bit

    t0 = time.perf_counter()
    simulate_bit(load_actuator(default_actuator_path()), [FaultSet()], [0.0], [1], workers=1)
    return time.perf_counter() - t0


def _child(case: str, workers: int | None, one_core: bool) -> dict[str, Any]:
    """One measured case in this process."""
    if one_core:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    from mapr_daemon.reasoner.training.workers import resolve

    warm = _warm()
    n_workers = resolve(workers)
    out: dict[str, Any] = {"warm_s": warm, "workers": n_workers}
    t0, c0 = time.perf_counter(), os.times()
    if case == "default":
        from mapr_daemon.cli.commands.dictionary import default_spec_path
        from mapr_daemon.ema.params import default_actuator_path, load_actuator
        from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
        from mapr_daemon.reasoner.training.dictionary_build import build

        def flown(fraction: float) -> None:
            if fraction >= 1.0:   # every BIT flown and (but the last batch) reduced to M
                out["flown_peak_mb"] = _peak_mb()

        d = build(load_actuator(default_actuator_path()),
                  DictionarySpec.load(default_spec_path()), flown, workers=n_workers)
        out["templates"] = len(d.templates)
    else:
        from mapr_daemon.cli.main import main

        err = io.StringIO()
        with tempfile.TemporaryDirectory() as cache:
            os.environ["MAPR_CACHE"] = cache
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                out["exit"] = main(["demo"])
        built = re.findall(r"built in [^\n]*?\)", err.getvalue())
        out["demo_says"] = built[-1] if built else "no build line"
    c1 = os.times()
    out.update(wall_s=time.perf_counter() - t0,
               cpu_s=(c1.user + c1.system) - (c0.user + c0.system), peak_mb=_peak_mb())
    return out


def _run(case: str, workers: int | None, one_core: bool) -> dict[str, Any]:
    """A case in a fresh process; its figures."""
    cmd = [sys.executable, __file__, "--child", case]
    if workers is not None:
        cmd += ["--workers", str(workers)]
    if one_core:
        cmd.append("--one-core")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{case} failed:\n{done.stderr}")
    figures: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", choices=("default", "demo"))
    ap.add_argument("--child", choices=("default", "demo"), help=argparse.SUPPRESS)
    ap.add_argument("--workers", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--one-core", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_child(args.child, args.workers, args.one_core)))
        return
    from mapr_daemon.reasoner.training.workers import usable_cores

    cores = usable_cores()
    print(f"machine: {os.cpu_count()} cores, {cores} usable; load average {_load()}")
    print("seeds: default spec seed_base 0 (runs 0..1495, pressure draws 7919); demo seed 1")
    cases = [("default", "default dictionary (build())", cores, False),
             ("default", "default dictionary (build())", 1, False),
             ("demo", "demo's first run (mapr demo, fresh cache)", None, False),
             ("demo", "demo's first run (mapr demo, fresh cache)", None, True)]
    walls: dict[tuple[str, int], float] = {}
    for case, name, workers, one_core in cases:
        if args.only and case != args.only:
            continue
        before = _load()
        f = _run(case, workers, one_core)
        pinned = ", pinned to one core" if one_core else ""
        print(f"{name}, {f['workers']} worker{'s' if f['workers'] > 1 else ''}{pinned}: "
              f"wall {f['wall_s']:.1f} s, CPU {f['cpu_s']:.1f} s (CPU/wall "
              f"{f['cpu_s'] / f['wall_s']:.2f}), peak RSS {f['peak_mb']:.0f} MB "
              f"({'under' if f['peak_mb'] <= LIMIT_MB else 'OVER'} {LIMIT_MB:.0f} MB); "
              f"warm-up {f['warm_s']:.1f} s; load average before {before}, after {_load()}")
        if "flown_peak_mb" in f:
            print(f"    peak RSS when the last BIT was flown {f['flown_peak_mb']:.0f} MB (the rest "
                  f"is the fit over M); {f['templates']} templates")
        if case == "demo":
            print(f"    the demo printed: {f['demo_says']} (exit {f['exit']})")
        walls[(case, f["workers"])] = f["wall_s"]
    for case in ("default", "demo"):
        many = [w for (c, w) in walls if c == case and w > 1]
        if many and (case, 1) in walls:
            w = max(many)
            print(f"{case}: wall with 1 worker / with {w}: "
                  f"{walls[(case, 1)] / walls[(case, w)]:.2f}x")


if __name__ == "__main__":
    main()
