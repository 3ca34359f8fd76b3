"""Run the test suite again and again while CPU hogs compete for every core.

    python bench/suite_under_load.py [--hogs N] [--runs R] [--target-s 480] [-- PYTEST ARGS]

A test whose outcome rests on the host clock (a fixed sleep, a small time-out) passes on a
quiet machine and fails when the scheduler is busy. This script makes the machine busy on
purpose: it starts ``--hogs`` plain busy-loop processes (default: one per core), then runs
``python3 -m pytest -q -p no:cacheprovider`` (the project's default options from pyproject,
as the README's test command runs it; arguments after ``--`` are added) ``--runs`` times in a
row. Per run it prints the passed / failed / error / skipped counts (from pytest's JUnit
report), the wall time, the CPU time of the pytest process tree (every descendant pytest
waited for, from the kernel's child rusage) and the load average; failed test ids are listed.
At the end: how many runs passed and the slowest wall time against the target (8 minutes).
The hogs are killed whatever happens (an exception, Ctrl-C), and so is a pytest still running.
Exit status 0 when every run passed.
"""

from __future__ import annotations

import argparse
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 480.0
"""The suite's wall-time target on the project's 2-core machine (8 minutes)."""
HOG = "while True:\n    pass\n"


@dataclass
class Run:
    """One pytest run's outcome."""

    passed: int = 0
    failed: int = 0
    errors: int = 0
    skipped: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    load: tuple[float, float, float] = (0.0, 0.0, 0.0)
    returncode: int = 0
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.returncode == 0 and not self.failed and not self.errors


def start_hogs(count: int) -> list[subprocess.Popen[bytes]]:
    """``count`` busy-loop processes (plain Python, no work but spinning)."""
    return [subprocess.Popen([sys.executable, "-c", HOG], stdin=subprocess.DEVNULL,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(count)]


def stop(processes: list[subprocess.Popen[bytes]]) -> None:
    """Kill each process this script started (by its own id) and reap it."""
    for proc in processes:
        if proc.poll() is None:
            proc.kill()
    for proc in processes:
        proc.wait()


def read_junit(path: Path, run: Run) -> None:
    """Counts and failed test ids from pytest's JUnit XML (missing if pytest died early)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return
    for case in root.iter("testcase"):
        name = f"{case.get('classname', '')}::{case.get('name', '')}"
        if case.find("failure") is not None:
            run.failed += 1
            run.failures.append(name)
        elif case.find("error") is not None:
            run.errors += 1
            run.failures.append(name + " (error)")
        elif case.find("skipped") is not None:
            run.skipped += 1
        else:
            run.passed += 1


def run_suite(extra: list[str], log_dir: Path, index: int,
              children: list[subprocess.Popen[bytes]]) -> Run:
    """One pytest run from the repository root; its output goes to ``log_dir``."""
    junit = log_dir / f"run{index}.xml"
    log = log_dir / f"run{index}.log"
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
               f"--junitxml={junit}", *extra]
    # the checkout this script lives in, not whatever copy of the package is installed
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.monotonic()
    with log.open("wb") as out:
        proc = subprocess.Popen(command, cwd=ROOT, env=env, stdout=out,
                                stderr=subprocess.STDOUT)
        children.append(proc)
        proc.wait()
        children.remove(proc)
    run = Run(wall_s=time.monotonic() - started, returncode=proc.returncode)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    run.cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    run.load = os.getloadavg()
    read_junit(junit, run)
    return run


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in args:
        cut = args.index("--")
        args, extra = args[:cut], args[cut + 1:]
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hogs", type=int, default=os.cpu_count() or 1,
                        help="busy-loop processes (default: one per core)")
    parser.add_argument("--runs", type=int, default=10, help="suite runs in a row")
    parser.add_argument("--target-s", type=float, default=TARGET_S,
                        help="wall-time target per run (default 480 s)")
    opts = parser.parse_args(args)
    if opts.hogs < 0 or opts.runs < 1:
        parser.error("--hogs must be >= 0 and --runs >= 1")

    log_dir = Path(tempfile.mkdtemp(prefix="mapr-suite-load-"))
    print(f"{opts.runs} run(s) of: python3 -m pytest -q -p no:cacheprovider {' '.join(extra)}"
          f"\nunder {opts.hogs} CPU hog(s) on {os.cpu_count()} core(s); logs in {log_dir}",
          flush=True)
    hogs: list[subprocess.Popen[bytes]] = []
    children: list[subprocess.Popen[bytes]] = []
    runs: list[Run] = []
    # Ctrl-C and SIGTERM both unwind through the finally below (even when started with
    # SIGINT ignored, as a background job is)
    previous = {sig: signal.signal(sig, signal.default_int_handler)
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        hogs = start_hogs(opts.hogs)
        for i in range(1, opts.runs + 1):
            run = run_suite(extra, log_dir, i, children)
            runs.append(run)
            print(f"run {i}: {'PASS' if run.ok else 'FAIL'} passed {run.passed}, failed "
                  f"{run.failed}, errors {run.errors}, skipped {run.skipped}; wall "
                  f"{run.wall_s:.1f} s, CPU {run.cpu_s:.1f} s, load average "
                  f"{run.load[0]:.2f} {run.load[1]:.2f} {run.load[2]:.2f}"
                  + ("" if run.ok or run.failures else f"; pytest exit {run.returncode}"),
                  flush=True)
            for name in run.failures:
                print(f"  failed: {name}", flush=True)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
    finally:
        stop(children)
        stop(hogs)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if not runs:
        return 130
    passed = sum(r.ok for r in runs)
    slowest = max(runs, key=lambda r: r.wall_s)
    mean = sum(r.wall_s for r in runs) / len(runs)
    print(f"{passed}/{len(runs)} runs passed; wall mean {mean:.1f} s, slowest "
          f"{slowest.wall_s:.1f} s (run {runs.index(slowest) + 1}) against the "
          f"{opts.target_s:.0f} s target: "
          f"{'within' if slowest.wall_s <= opts.target_s else 'OVER'}", flush=True)
    return 0 if passed == len(runs) and len(runs) == opts.runs else 1


if __name__ == "__main__":
    sys.exit(main())
