"""Chapter 10 at full speed: file -> records against pychapter10, the JSON writer, decode --icd.

First, per file, the monitor API at the library's speed: ``open_monitor("chapter10",
path=...)`` iterated as a python-can user would (``for record in monitor``) and its batch
API (``for batch in monitor.batches()``), each as a ratio to pychapter10's iteration of the
same file's 1553 messages (targets: records >= 1.0x, batches >= 2x), measured in turn in
the same rounds.

    python bench/chapter10_speed.py [--seconds 60] [--repeat 40] [--seed N] [--runs 3]
                                    [--icd-only]

Files (all made here, in a temporary folder):

* dense: a fully loaded bus of mixed traffic (32-word BC-RT, 16-word RT-BC, RT-RT, mode
  codes, both buses; bench/recording.py's mix) through the project's writer;
* sample xN: the real sample recording, its packets of the types pychapter10 knows
  (pychapter10's iterator stops on the others) repeated N times, when it is next to the
  repository;
* icd: the ICD's messages with random words (seeded, printed) at 1 ms intervals, half the
  messages, the other half traffic it does not describe.

Every figure is CPU time of this process (the machine is shared; wall time beside it) and
each rate is the best of ``--runs`` runs (three by default), measured side by side in one
run (``--icd-only``: the icd file's figures only):

* pychapter10: ``for packet in C10(f): for message in packet`` (1553 packets);
* monitor records / monitor batches: ``open_monitor("chapter10", path=f)``, then ``for
  record in monitor`` / ``for batch in monitor.batches()`` (the monitor's statistics kept
  as always);
* MAPR batches: :meth:`Chapter10Reader.batches` with ``arinc429=False`` (1553 records as
  arrays, as pychapter10's loop yields 1553 messages only; replay reads so); the same with
  ARINC 429 decoded too (each ARINC packet then ends a 1553 batch, to keep file order, as
  ``mapr decode`` needs); MAPR records: each message made a MonitorRecord;
  per-message: ``batched=False`` (pychapter10's parse, one record at a time: the old path);
* JSON writer: :func:`json_lines` per batch against ``json.dumps`` per record;
* ``mapr decode`` and ``mapr decode --icd`` on the icd file (in process, to /dev/null), the
  values written by each writer (``repr``, and the compiled one a long decode turns to);
  the same two commands in fresh interpreters, start-up included (CPU of the child); the
  parts of ``decode --icd`` with the compiled writer; and the per-record ICD path
  ``decode --icd`` used before (one run).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from datetime import datetime
from pathlib import Path

import numpy as np
from chapter10 import C10
from chapter10.c10 import TYPES

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.recording import mixed
from bench.seeds import fresh
from drivers.chapter10.ms1553_json import json_lines
from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.walker import PacketWalker
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.monitor import open_monitor
from mapr_daemon.cli.icdview.view import IcdView
from mapr_daemon.cli.main import main as mapr
from mapr_daemon.cli.traffic.chapter10_decode import BATCH_MESSAGES
from mapr_daemon.icd import load_icd

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / ".." / "shared" / "data" / "chapter10" / "sample.c10"
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


RUNS = [3]
"""Runs each figure is the best of (``--runs``)."""


def best(run: Callable[[], int], times: int = 0) -> tuple[float, float, int]:
    """(CPU s, wall s, items) of the fastest of ``times`` runs (``--runs`` if 0), by CPU."""
    times = times or RUNS[0]
    results = []
    for _ in range(times):
        cpu, wall = time.process_time(), time.perf_counter()
        items = run()
        results.append((time.process_time() - cpu, time.perf_counter() - wall, items))
    return min(results)


def pychapter10(path: Path) -> int:
    n = 0
    for packet in C10(str(path)):
        if packet.data_type == 0x19:
            for _ in packet:
                n += 1
    return n


def monitor_records(path: Path) -> int:
    """``for record in open_monitor("chapter10", path=...)``, as a python-can user reads."""
    n = 0
    with open_monitor("chapter10", path=str(path)) as monitor:
        for _ in monitor:
            n += 1
    return n


def monitor_batches(path: Path) -> int:
    """The monitor API's batches: ``for batch in monitor.batches()`` (numpy columns)."""
    with open_monitor("chapter10", path=str(path)) as monitor:
        return sum(len(batch) for batch in monitor.batches())


def mapr_batches(path: Path, arinc429: bool = False) -> int:
    return sum(len(b.ms1553) for b in Chapter10Reader(path, arinc429=arinc429).batches()
               if b.ms1553 is not None)


def mapr_with_arinc(path: Path) -> int:
    return mapr_batches(path, arinc429=True)


def mapr_records(path: Path) -> int:
    return sum(len(b.records) for b in Chapter10Reader(path, arinc429=False).batches())


def per_message(path: Path) -> int:
    return sum(len(b.records) for b in Chapter10Reader(path, batched=False))


def json_batched(path: Path) -> int:
    return sum(len(json_lines(b.ms1553)) for b in Chapter10Reader(path).batches()
               if b.ms1553 is not None)


def json_per_record(path: Path) -> int:
    n = 0
    for batch in Chapter10Reader(path).batches():
        for record in batch.records:
            line = record.to_json()
            line["channel"] = record.extra["channel"]
            if "time" in record.extra:
                line["time"] = record.extra["time"]
            n += len(json.dumps(line)) > 0
    return n


def decode_icd_per_record(path: Path) -> int:
    """What ``mapr decode --icd`` did before batches: one ICD decode and one json.dumps
    per record."""
    view = IcdView(str(ICD))
    n = 0
    for batch in Chapter10Reader(path, batched=False):
        for record in batch.records:
            line = record.to_json()
            line["channel"] = record.extra["channel"]
            values = view.values(record)
            if values is not None:
                line["values"] = values
            n += len(json.dumps(line)) > 0
    return n


def decode(*argv: str) -> int:
    with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink), \
            contextlib.redirect_stderr(io.StringIO()):
        assert mapr(["decode", *argv]) == 0
    return 1


@contextlib.contextmanager
def values_writer(after: int) -> Iterator[None]:
    """``decode --icd`` in this process with the compiled values writer from ``after``
    messages with values on (0: always; huge: never), whether numba is loaded or not."""
    import mapr_daemon.cli.icdview.batch as batch_module

    saved = batch_module.COMPILED_AFTER, batch_module._numba_loaded
    batch_module.COMPILED_AFTER, batch_module._numba_loaded = after, lambda: False
    try:
        yield
    finally:
        batch_module.COMPILED_AFTER, batch_module._numba_loaded = saved


def writer_decode(after: int, path: Path) -> int:
    """``mapr decode --icd`` of ``path`` in this process, the compiled values writer from
    ``after`` messages with values on (see :func:`values_writer`)."""
    with values_writer(after):
        return decode("--icd", str(ICD), str(path))


def interleaved(runs: dict[str, Callable[[], int]]) -> dict[str, tuple[float, float]]:
    """(CPU s, wall s) of the fastest run of each of ``runs``, by CPU: ``--runs`` rounds,
    each running them all in turn, so a busy spell of a shared machine weighs on all alike."""
    return {label: (cpu, wall) for label, (cpu, wall, _) in in_turn(runs).items()}


def in_turn(runs: dict[str, Callable[[], int]]) -> dict[str, tuple[float, float, int]]:
    """(CPU s, wall s, items) of the fastest run of each of ``runs``, by CPU, ``--runs``
    rounds of all of them in turn (see :func:`interleaved`)."""
    fastest: dict[str, tuple[float, float, int]] = {}
    for _ in range(RUNS[0]):
        for label, run in runs.items():
            cpu, wall = time.process_time(), time.perf_counter()
            items = run()
            taken = (time.process_time() - cpu, time.perf_counter() - wall, items)
            fastest[label] = min(fastest.get(label, taken), taken)
    return fastest


def monitor_api(files: list[tuple[str, Path]]) -> None:
    """The monitor API against pychapter10 on each file, the three taken in turn in each
    of ``--runs`` rounds: rates, CPU beside wall time, the ratios and the load."""
    print(f"\nthe monitor API against pychapter10 (each the best of {RUNS[0]} rounds, the "
          "three in turn in each round; CPU time of this process, wall beside it)")
    for name, path in files:
        print(f"{name}: {path.stat().st_size / 2**20:.1f} MiB, load average "
              f"{os.getloadavg()[0]:.2f}")
        fastest = in_turn({
            "pychapter10": lambda path=path: pychapter10(path),
            "monitor records": lambda path=path: monitor_records(path),
            "monitor batches": lambda path=path: monitor_batches(path)})
        counts = {n for _, _, n in fastest.values()}
        assert len(counts) == 1, f"the three counted different messages: {fastest}"
        rates = {}
        for label, (cpu, wall, n) in fastest.items():
            rates[label] = n / cpu
            print(f"  {label:<16} {n:>9,} messages  {cpu:7.3f} s CPU ({wall:7.3f} s wall)  "
                  f"{n / cpu:>12,.0f} msg/s CPU ({n / wall:,.0f} wall)")
        base = rates["pychapter10"]
        print(f"  through open_monitor: records {rates['monitor records'] / base:.2f}x, "
              f"batches {rates['monitor batches'] / base:.2f}x pychapter10 (CPU; targets "
              f"1.0x and 2x)")


def icd_parts(path: Path) -> dict[str, float]:
    """CPU s of the parts of ``decode --icd`` (compiled writer) on ``path``, each the best
    of ``--runs``: reading the batches, their values text (and the same by the ``repr``
    writer), their JSON lines without and with the values, joining the lines."""
    from mapr_daemon.cli.icdview.batch import BatchValues, batch_values_json

    batches = [b.ms1553 for b in Chapter10Reader(path).batches(BATCH_MESSAGES)
               if b.ms1553 is not None]
    values = BatchValues(load_icd(ICD))
    tails = [values(b) for b in batches]
    lines = [json_lines(b, t) for b, t in zip(batches, tails, strict=True)]
    parts: dict[str, Callable[[], object]] = {
        "read": lambda: [b.ms1553 for b in Chapter10Reader(path).batches(BATCH_MESSAGES)],
        "values text": lambda: [values(b) for b in batches],
        "values text by the repr writer": lambda: [batch_values_json(values.icd, b)
                                                   for b in batches],
        "lines without values": lambda: [json_lines(b) for b in batches],
        "lines with values": lambda: [json_lines(b, t)
                                      for b, t in zip(batches, tails, strict=True)],
        "join": lambda: ["".join(x) for x in lines]}
    fastest = {}
    for label, run in parts.items():
        taken = []
        for _ in range(RUNS[0]):
            cpu = time.process_time()
            run()
            taken.append(time.process_time() - cpu)
        fastest[label] = min(taken)
    return fastest


def fresh_decode(*argv: str) -> float:
    """CPU s (user + system) of ``mapr decode ARGV`` in a fresh interpreter, start-up
    included, output discarded."""
    before = os.times()
    subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "decode", *argv],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True, cwd=ROOT,
                   env={**os.environ, "PYTHONPATH": str(ROOT)})
    after = os.times()
    return (after.children_user - before.children_user +
            after.children_system - before.children_system)


def sample_repeated(target: Path, times: int) -> bool:
    if not SAMPLE.is_file():
        return False
    walker = PacketWalker(SAMPLE, frozenset(TYPES))
    packets = [item.raw for item in walker]
    walker.close()
    target.write_bytes(b"".join(packets) * times)
    return True


def icd_traffic(seconds: float, seed: int) -> list[MonitorRecord]:
    icd = load_icd(ICD)
    rng = np.random.default_rng(seed)
    records = []
    for i in range(int(seconds * 1000)):
        t = i * 1_000_000
        if i % 2:
            message = icd.messages[int(rng.integers(len(icd.messages)))]
            command, count = message.command, message.word_count
        else:
            command = int(rng.integers(20, 28)) << 11 | 2 << 5 | 4
            count = 4
        tx = command >> 10 & 1
        data = tuple(int(w) for w in rng.integers(0, 1 << 16, count))
        records.append(MonitorRecord(t, "AB"[i % 2], TransferFormat.RT_BC if tx
                                     else TransferFormat.BC_RT, command, data=data,
                                     status=(command >> 11 << 11,), gaps_ns=(8_000,)))
    return records


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="bus time of each file")
    parser.add_argument("--repeat", type=int, default=40, help="copies of the sample")
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--runs", type=int, default=3, help="runs each figure is the best of")
    parser.add_argument("--icd-only", action="store_true",
                        help="only the decode / decode --icd figures")
    args = parser.parse_args()
    RUNS[0] = max(1, args.runs)
    seed = fresh(args.seed)
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as folder:
        dense = Path(folder) / "dense.c10"
        with Chapter10Writer(dense, start_time=datetime(2026, 1, 1)) as writer:
            writer.write(mixed(args.seconds))
        files = [] if args.icd_only else [("dense", dense)]
        repeated = Path(folder) / "sample.c10"
        if args.icd_only:
            pass
        elif sample_repeated(repeated, args.repeat):
            files.append((f"sample x{args.repeat}", repeated))
        else:
            print(f"sample recording not at {SAMPLE}: skipped")
        icd_file = Path(folder) / "icd.c10"
        with Chapter10Writer(icd_file, start_time=datetime(2026, 1, 1)) as writer:
            writer.write(icd_traffic(args.seconds, seed))
        print(f"inputs: dense = bench/recording.py's mixed() for {args.seconds:g} s of bus "
              f"through the project's writer (no seed: the same traffic every run); sample = "
              f"{SAMPLE.resolve()} x{args.repeat}; icd = seed {seed}")
        mapr_batches(dense)   # imports, warms the caches
        monitor_records(dense)
        monitor_api(files)
        for name, path in files:
            size = path.stat().st_size / 2**20
            print(f"\n{name}: {size:.1f} MiB")
            rates = {}
            for label, run in (("pychapter10", pychapter10), ("MAPR batches", mapr_batches),
                               ("MAPR batches + ARINC 429", mapr_with_arinc),
                               ("MAPR records", mapr_records),
                               ("MAPR per-message (old)", per_message)):
                cpu, wall, n = best(lambda run=run, path=path: run(path))
                rates[label] = n / cpu
                print(f"  {label:<24} {n:>9,} messages  {n / cpu:>12,.0f} msg/s CPU "
                      f"({n / wall:,.0f} wall)")
            base = rates["pychapter10"]
            print(f"  ratio to pychapter10: batches {rates['MAPR batches'] / base:.2f}x, "
                  f"records {rates['MAPR records'] / base:.2f}x, "
                  f"per-message {rates['MAPR per-message (old)'] / base:.2f}x")
            cpu_b, _, n = best(lambda path=path: json_batched(path))
            cpu_r, _, _ = best(lambda path=path: json_per_record(path))
            print(f"  JSON lines (read + write): batched {n / cpu_b:,.0f} msg/s CPU, "
                  f"json.dumps per record {n / cpu_r:,.0f} msg/s CPU ({cpu_r / cpu_b:.1f}x)")
        print(f"\nicd: {icd_file.stat().st_size / 2**20:.1f} MiB, "
              f"{int(args.seconds * 1000):,} messages")
        icd_runs = {"decode": lambda: decode(str(icd_file)),
                    "repr writer": lambda: writer_decode(10**12, icd_file),
                    "compiled writer": lambda: writer_decode(0, icd_file)}
        writer_decode(0, icd_file)   # loads the kernels
        fastest = interleaved(icd_runs)
        plain, plain_wall = fastest["decode"]
        print(f"  (each the best of {RUNS[0]} rounds, the three taken in turn in each round)")
        print(f"  mapr decode        {plain:.3f} s CPU ({plain_wall:.3f} s wall)")
        for label in ("repr writer", "compiled writer"):
            with_icd, icd_wall = fastest[label]
            print(f"  mapr decode --icd, {label:<15} {with_icd:.3f} s CPU ({icd_wall:.3f} s "
                  f"wall): {with_icd / plain:.2f}x decode")
        cold = {label: float("inf") for label in ("decode", "decode --icd")}
        for _ in range(RUNS[0]):   # in turn, as above
            for label, argv in (("decode", ()), ("decode --icd", ("--icd", str(ICD)))):
                cold[label] = min(cold[label], fresh_decode(*argv, str(icd_file)))
        print(f"  fresh interpreters (start-up included; {int(args.seconds * 500):,} messages "
              f"with values: the repr writer): decode {cold['decode']:.3f} s CPU, "
              f"decode --icd {cold['decode --icd']:.3f} s CPU "
              f"({cold['decode --icd'] / cold['decode']:.2f}x)")
        with values_writer(0):
            parts = icd_parts(icd_file)
        print("  decode --icd, compiled writer, by part (CPU s): " + ", ".join(
            f"{label} {cpu:.3f}" for label, cpu in parts.items()))
        old, old_wall, _ = best(lambda: decode_icd_per_record(icd_file), times=1)
        print(f"  the per-record --icd path: {old:.2f} s CPU ({old_wall:.2f} s wall, one "
              f"run)")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    sys.exit(main())
