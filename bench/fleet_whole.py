"""``mapr fleet``'s per-worker real-time factor on whole-flight recordings, in-flight tracking on.

    python3 bench/fleet_whole.py [--tails 2] [--flights 4] [--scale 0.5] [--seed N]
                                 [--dictionary D.npz --prognosis P.npz] [--bits-only-too]

(default models: the demo's pre-built aileron dictionary and prognostic model)

Writes an archive of whole flights (:mod:`mapr_daemon.testbed.whole_recording`: the testbed
aircraft flying the whole-flight profile, taxi to taxi, ``--scale`` times the 255 s profile's
phase lengths, a PBIT at power-up on every flight; ``TAIL/flight-NNNN.ch10``; the first tail's
friction aging, the others healthy), then runs it through :class:`FleetRun` (what ``mapr
fleet`` runs) on a local Dask cluster of ONE worker with ``reasoner.inflight`` on (the
default): every recording decoded, its BIT diagnosed, its in-flight tracker run over the
traffic between BITs, rows trended and stored by the client. The worker's CPU time is read on
the worker itself (``time.process_time`` before and after, through ``Client.run``), so the
factor is recorded bus seconds over worker CPU seconds, one run, nothing combined. A warm-up
run of the first recording into a scratch catalog comes first (the worker loads the
dictionary and compiles its kernels on its first task); its cost is printed apart. The
client's own CPU (trend refits, catalog writes) and the wall time are printed beside it.
``--bits-only-too`` runs the same archive again with ``reasoner.inflight: false``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from datetime import timedelta
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master

from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.fleet.archive import Recording, discover
from mapr_daemon.fleet.cluster import close_client, local_client
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.runner import FleetRun
from mapr_daemon.pipeline.settings import AssetConfig, ReasonerConfig
from mapr_daemon.service.config import Config
from mapr_daemon.testbed.fleet import FIRST_DAY
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.whole_recording import flight_seconds, record_flight, whole_template

MODELS = Path(__file__).resolve().parents[1] / "mapr_daemon" / "testbed" / "models"
"""The demo's pre-built aileron models: the default dictionary and prognostic model."""
TEMPLATE: list[FlightTemplate] = []
"""The archive's whole-flight template, set before the writing pool forks."""


def _write(root: str, tail: str, flight: int, seed: int, friction: float) -> str:
    path = Path(root) / tail / f"flight-{flight:04d}.ch10"
    path.parent.mkdir(parents=True, exist_ok=True)
    faults = FaultSet.of([Fault("friction", friction)]) if friction != 1.0 else FaultSet()
    record_flight(path, TEMPLATE[0], faults, seed=seed,
                  start=FIRST_DAY + timedelta(days=flight - 1, minutes=int(tail[1:])),
                  tail=tail)
    return str(path)


def archive(root: Path, tails: int, flights: int, rng: np.random.Generator) -> None:
    """``tails`` x ``flights`` whole flights of :data:`TEMPLATE` under ``root``."""
    started = time.monotonic()
    with ProcessPoolExecutor(2) as pool:
        jobs = [pool.submit(_write, str(root), f"N{101 + t}", f + 1,
                            int(rng.integers(2**31)), 1.0 + (0.1 * f if t == 0 else 0.0))
                for t in range(tails) for f in range(flights)]
        for j in jobs:
            j.result()
    print(f"archive: {tails} tails x {flights} whole flights written in "
          f"{time.monotonic() - started:.0f} s (tail N101's friction +10 % a flight)",
          flush=True)


def run(recordings: list[Recording], config: FleetConfig, catalog: Path,
        warm: Path) -> dict[str, float]:
    """One worker: a warm-up on the first recording, then the archive, timed."""
    client = local_client(1, dashboard=False)
    try:
        cpu0 = client.run(time.process_time)
        with CatalogWriter(warm, durability="crash") as writer:
            writer.open_session(backend="fleet", config_hash=config.digest())
            FleetRun(client, writer, config).run(recordings[:1])
        cpu1 = client.run(time.process_time)
        with CatalogWriter(catalog, durability="crash") as writer:
            writer.open_session(backend="fleet", config_hash=config.digest())
            c0, started = time.process_time(), time.monotonic()
            summary = FleetRun(client, writer, config).run(recordings)
            wall, client_cpu = time.monotonic() - started, time.process_time() - c0
        cpu2 = client.run(time.process_time)
    finally:
        close_client(client)
    (w,) = cpu0
    assert summary.stored == len(recordings) and not summary.failed, summary
    return {"warm": cpu1[w] - cpu0[w], "cpu": cpu2[w] - cpu1[w], "wall": wall,
            "client": client_cpu, "mean": statistics.fmean(summary.task_s),
            "worst": max(summary.task_s), "bits": summary.bits, "rul": summary.rul}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tails", type=int, default=2)
    ap.add_argument("--flights", type=int, default=4)
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--seed", type=int)
    ap.add_argument("--dictionary", type=Path)
    ap.add_argument("--prognosis", type=Path)
    ap.add_argument("--bits-only-too", action="store_true")
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/fleet_whole.py --tails {args.tails} --flights "
                             f"{args.flights} --scale {args.scale:g}")
    t0, c0 = time.monotonic(), time.process_time()
    args.dictionary = args.dictionary or MODELS / "dictionary-aileron-uav-2000hz.npz"
    args.prognosis = args.prognosis or MODELS / "prognosis-aileron-uav-2000hz.npz"
    print(f"dictionary {args.dictionary}\nprognosis {args.prognosis}")
    rng = np.random.default_rng(seed)
    started = time.monotonic()
    TEMPLATE.append(whole_template(int(rng.integers(2**31)), args.scale, bit=True))
    span = flight_seconds(TEMPLATE[0])
    print(f"whole-flight profile: {span:.1f} s of bus a flight, {len(TEMPLATE[0].records)} "
          f"messages, a PBIT at power-up; flown over the bus once in "
          f"{time.monotonic() - started:.0f} s", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch) / "archive"
        archive(root, args.tails, args.flights, rng)
        recordings, bad = discover([root])
        assert not bad and len(recordings) == args.tails * args.flights, bad
        bus = span * len(recordings)
        for inflight in (True, False) if args.bits_only_too else (True,):
            config = FleetConfig(Config(
                reasoner=ReasonerConfig(dictionary=str(args.dictionary), inflight=inflight),
                assets=(AssetConfig(prognosis=str(args.prognosis)),)))
            r = run(recordings, config, Path(scratch) / f"fleet-{inflight}.db",
                    Path(scratch) / f"warm-{inflight}.db")
            print(f"1 worker, in-flight tracking {'ON' if inflight else 'off'}: "
                  f"{len(recordings)} recordings, {bus:.0f} s of bus; worker CPU "
                  f"{r['cpu']:.2f} s = {bus / r['cpu']:.0f}x real time per worker (warm-up "
                  f"task before it: {r['warm']:.2f} s CPU); per task {r['mean']:.2f} s mean, "
                  f"{r['worst']:.2f} s worst wall = {span / r['worst']:.0f}x worst; wall "
                  f"{r['wall']:.1f} s ({bus / r['wall']:.0f}x), client CPU {r['client']:.2f} s; "
                  f"{r['bits']:.0f} BITs ({r['rul']:.0f} with a RUL); load average "
                  f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    print(f"total wall {time.monotonic() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s in "
          f"this process; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
