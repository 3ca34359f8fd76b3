"""Fleet analysis throughput: ``mapr fleet``'s path on a synthetic archive, 1 and 2 workers.

    python bench/fleet.py [--tails 20] [--flights 10] [--workers 1,2] [--seed N]
                          [--archive DIR] [--dictionary FILE] [--prognosis FILE]

Writes a synthetic fleet archive (:mod:`mapr_daemon.testbed.fleet`: ``--tails`` x
``--flights`` recordings of 2 s of bus traffic, a BIT on every flight, half the tails aging,
each flight declared 1.5 flight hours), then runs it through :class:`FleetRun` (what ``mapr
fleet`` runs) on a fresh local Dask cluster and a fresh catalog for each worker count. Prints,
per worker count: wall time (cluster start excluded, worker warm-up included: each worker
loads the dictionary and compiles its kernels on its first task), flight hours per wall hour,
recorded bus time per wall second (the honest rate: the declared hours are synthetic), the
per-task cost (mean, median, worst) and the scaling efficiency against one worker. Then checks
the catalog: every recording stored once, and which tails have anomaly events against the
manifest's truth. The dictionary defaults to the one ``mapr demo`` builds from the shipped
spec (cached); the prognostic model to one built once for it with the default
:class:`BuildSpec` (cached beside it, ~1.5 min), so each tail's actuator is trended on the
client: the run prints how many BITs got a RUL, per tail kind (aging or healthy). The
machine is shared: the load average is printed beside the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sqlite3
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from seeds import fresh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.fleet.archive import discover
from mapr_daemon.fleet.cluster import close_client, local_client
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.runner import FleetRun
from mapr_daemon.pipeline.settings import AssetConfig, ReasonerConfig
from mapr_daemon.service.config import Config
from mapr_daemon.testbed.fleet import MANIFEST, FleetSpec, generate


def archive(root: Path, spec: FleetSpec, jobs: int) -> dict[str, object]:
    manifest = root / MANIFEST
    if manifest.exists():
        known = json.loads(manifest.read_text())
        if (known["seed"], known["tails"], known["flights"]) == (spec.seed, spec.tails,
                                                                 spec.flights):
            print(f"archive {root}: reused ({spec.tails} tails x {spec.flights} flights)")
            return dict(known)
    started = time.monotonic()
    with ProcessPoolExecutor(jobs) as pool:
        made = generate(root, spec, map_tails=pool.map)
    print(f"archive {root}: {spec.tails} tails x {spec.flights} flights written in "
          f"{time.monotonic() - started:.0f} s with {jobs} processes")
    return made


def default_dictionary() -> Path:
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.testbed.demo_reasoner import cached_dictionary

    actuator = default_actuator_path()
    return cached_dictionary(load_actuator(actuator), Path(actuator))


def default_prognosis(dictionary: Path) -> Path:
    """A prognostic model for ``dictionary``, built once with the default spec and cached."""
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.prognosis_build import build_prognostic_model

    path = dictionary.with_name(f"prognosis-{dictionary.stem}.npz")
    if not path.exists():
        started = time.monotonic()
        model = build_prognostic_model(Dictionary.load(dictionary),
                                       load_actuator(default_actuator_path()))
        model.save(path)
        print(f"prognosis {path}: built in {time.monotonic() - started:.0f} s")
    return path


def run(root: Path, dictionary: Path, prognosis: Path, workers: int, catalog: Path
        ) -> dict[str, float]:
    recordings, bad = discover([root])
    assert not bad, bad
    configs = FleetConfig(Config(reasoner=ReasonerConfig(dictionary=str(dictionary)),
                                 assets=(AssetConfig(prognosis=str(prognosis)),)))
    client = local_client(workers, dashboard=False)
    try:
        with CatalogWriter(catalog, durability="crash") as writer:
            writer.open_session(backend="fleet", config_hash=configs.digest())
            started = time.monotonic()
            summary = FleetRun(client, writer, configs).run(recordings)
            wall = time.monotonic() - started
    finally:
        close_client(client)
    assert summary.stored == len(recordings) and not summary.failed, summary
    tasks = summary.task_s
    recorded = 2.0 * len(recordings)
    return {"wall": wall, "hours": summary.hours, "rate": summary.hours / (wall / 3600),
            "bus_x": recorded / wall, "mean": statistics.fmean(tasks),
            "median": statistics.median(tasks), "worst": max(tasks), "n": len(tasks),
            "events": summary.events, "bits": summary.bits, "rul": summary.rul}


def check(catalog: Path, manifest: dict[str, object]) -> None:
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        rows, distinct = conn.execute("SELECT count(*), count(DISTINCT digest) FROM recordings"
                                      ).fetchone()
        flagged = {str(a).split("/")[0] for (a,) in
                   conn.execute("SELECT DISTINCT asset FROM events")}
        trended = conn.execute("SELECT tail, flight, rul FROM bits ORDER BY id").fetchall()
    truth = manifest["truth"]
    assert isinstance(truth, dict)
    aging = {t for t, v in truth.items() if v}
    healthy = set(truth) - aging
    print(f"catalog: {rows} recordings rows, {distinct} distinct; tails with anomaly events: "
          f"{len(flagged & aging)}/{len(aging)} aging, {len(flagged & healthy)}/{len(healthy)} "
          "healthy")
    in_order = all([f for t, f, _ in trended if t == tail] ==
                   sorted(f for t, f, _ in trended if t == tail) for tail in truth)
    for name, tails in (("aging", aging), ("healthy", healthy)):
        mine = [r for r in trended if r[0] in tails]
        print(f"trend: {name} tails: {len(mine)} BITs, {sum(r[2] is not None for r in mine)} "
              f"with a RUL; each tail's BITs stored in flight order: {in_order}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tails", type=int, default=20)
    ap.add_argument("--flights", type=int, default=10)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--seed", type=int)
    ap.add_argument("--archive", type=Path)
    ap.add_argument("--dictionary", type=Path)
    ap.add_argument("--prognosis", type=Path)
    args = ap.parse_args()
    seed = fresh(args.seed)
    counts = [int(w) for w in args.workers.split(",")]
    dictionary = args.dictionary or default_dictionary()
    prognosis = args.prognosis or default_prognosis(dictionary)
    print(f"dictionary {dictionary}\nprognosis {prognosis}")
    with tempfile.TemporaryDirectory() as scratch:
        root = args.archive or Path(scratch) / "archive"
        spec = FleetSpec(tails=args.tails, flights=args.flights, seed=seed, degrading=0.5,
                         flight_s=2.0, flight_hours=1.5)
        manifest = archive(root, spec, max(counts))
        results = {}
        for workers in counts:
            catalog = Path(scratch) / f"fleet-{workers}.db"
            r = results[workers] = run(root, dictionary, prognosis, workers, catalog)
            print(f"{workers} worker(s): {r['n']:.0f} recordings, {r['hours']:.0f} flight h in "
                  f"{r['wall']:.1f} s = {r['rate']:.0f} flight h per wall h; bus time "
                  f"{r['bus_x']:.1f}x real time; per task {r['mean']:.2f} s mean, "
                  f"{r['median']:.2f} s median, {r['worst']:.2f} s worst; {r['bits']:.0f} "
                  f"BITs ({r['rul']:.0f} with a RUL), {r['events']:.0f} events; load average "
                  f"{os.getloadavg()[0]:.1f}")
            check(catalog, manifest)
        base = counts[0]
        for workers in counts[1:]:
            speedup = results[workers]["rate"] / results[base]["rate"]
            print(f"scaling {base} -> {workers} workers: {speedup:.2f}x, efficiency "
                  f"{speedup / (workers / base):.0%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
