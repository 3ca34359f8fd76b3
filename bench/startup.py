"""Start-up cost of the ``mapr`` command line: what a bus engineer waits for before any output.

    python bench/startup.py [--runs 7] [--sample PATH]

Prints, over ``--runs`` fresh interpreters each (min / median / max):

* the import time of each subcommand's module (what building its parser costs, measured
  inside the child with ``time.perf_counter`` around the import, the ``mapr_daemon`` package
  included);
* wall and CPU time (user + system, from the child's resource usage) of ``mapr --help``,
  ``mapr decode --help`` and ``mapr decode SAMPLE > /dev/null`` on the real Chapter 10 sample
  recording (skipped, with the reason, when the file is absent);
* where the CPU time of that decode goes: importing numpy, importing the rest, decoding.

Commands run as ``python -m mapr_daemon.cli.main`` from this checkout, which is what the
``mapr`` script runs. The load average is printed before and after: the machine may be shared,
and a busy one inflates every figure. No random input, so no seed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT.parent / "shared" / "data" / "chapter10" / "sample.c10"
"""Where the repository's tests look for the real recording (kept next to the repository)."""

sys.path.insert(0, str(ROOT))
from mapr_daemon.cli.main import MODULES, SUBCOMMANDS  # noqa: E402  (this checkout, not an install)


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def import_seconds(module: str) -> float:
    """Seconds a fresh interpreter spends importing ``module``."""
    code = (f"import time\nt = time.perf_counter()\nimport {module}\n"
            "print(time.perf_counter() - t)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_env(), check=True)
    return float(done.stdout)


def command_seconds(args: list[str]) -> tuple[float, float, int]:
    """Wall and CPU seconds of one ``mapr`` run (stdout to /dev/null), and its exit code."""
    with open(os.devnull, "wb") as sink:
        start = time.perf_counter()
        child = subprocess.Popen([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                                 stdout=sink, stderr=subprocess.DEVNULL, env=_env())
        _, status, usage = os.wait4(child.pid, 0)
        wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    return wall, usage.ru_utime + usage.ru_stime, child.returncode


SPLIT = """
import contextlib, io, sys, time
t0 = time.process_time()
import numpy
t1 = time.process_time()
import drivers.chapter10.ms1553_json, drivers.chapter10.reader, mapr_daemon.cli.commands.decode
import mapr_daemon.cli.traffic.decode_filter, mapr_daemon.cli.traffic.decode_text
import mapr_daemon.cli.icdview.view
from mapr_daemon.cli.main import main
t2 = time.process_time()
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    main(["decode", sys.argv[1]])
print(t1 - t0, t2 - t1, time.process_time() - t2)
"""


def decode_split(sample: Path) -> tuple[float, float, float]:
    """CPU seconds, in one fresh interpreter, of importing numpy, of importing the rest of
    what ``mapr decode FILE.c10`` imports, and of the decode itself (output discarded)."""
    done = subprocess.run([sys.executable, "-c", SPLIT, str(sample)], capture_output=True,
                          text=True, env=_env(), check=True)
    numpy_s, rest_s, run_s = map(float, done.stdout.split())
    return numpy_s, rest_s, run_s


def spread(values: list[float]) -> str:
    return (f"{min(values):6.3f} {statistics.median(values):6.3f} {max(values):6.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="fresh interpreters per figure")
    parser.add_argument("--sample", type=Path, default=SAMPLE,
                        help="the Chapter 10 recording to decode")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}; {args.runs} runs each; "
          f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} (1, 5 min)")
    print("no random input: no seed")
    print()
    print("import of each subcommand module, s        min    med    max")
    bare = [import_seconds("mapr_daemon") for _ in range(args.runs)]
    print(f"  {'(mapr_daemon package alone)':<36} {spread(bare)}")
    for name in SUBCOMMANDS:
        module = MODULES.get(name, f"mapr_daemon.cli.commands.{name}")
        times = [import_seconds(module) for _ in range(args.runs)]
        print(f"  {module:<36} {spread(times)}")
    print()
    cases: list[tuple[str, list[str]]] = [("mapr --help", ["--help"]),
                                          ("mapr decode --help", ["decode", "--help"])]
    if args.sample.is_file():
        cases.append((f"mapr decode {args.sample.name} > /dev/null",
                      ["decode", str(args.sample)]))
    else:
        print(f"skipped: mapr decode of the sample recording (no file at {args.sample})")
    print(f"{'command':<40} {'wall s: min    med    max':>24}   {'cpu s: min    med    max':>23}")
    for label, argv in cases:
        walls, cpus, codes = [], [], set()
        for _ in range(args.runs):
            wall, cpu, code = command_seconds(argv)
            walls.append(wall)
            cpus.append(cpu)
            codes.add(code)
        print(f"{label:<40} {spread(walls):>24}   {spread(cpus):>23}"
              f"   exit {','.join(map(str, sorted(codes)))}")
    if args.sample.is_file():
        split = [decode_split(args.sample) for _ in range(args.runs)]
        print()
        print(f"mapr decode {args.sample.name}, CPU s in one process     min    med    max")
        for k, label in enumerate(("import numpy", "import the rest", "decode (to memory)")):
            print(f"  {label:<44} {spread([row[k] for row in split])}")
    print()
    print(f"load average after: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} (1, 5 min)")


if __name__ == "__main__":
    main()
