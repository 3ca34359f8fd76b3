"""Fault catalog speed: batched inserts per second, and list queries over 1 M events.

    python bench/catalog.py [--events 1000000] [--batch 5000] [--durability power-loss]
                            [--persist 1]

Writes a fresh catalog in a temporary directory through :class:`CatalogWriter` (WAL,
``synchronous=FULL`` by default, one transaction per batch, JSON parameters and evidence as
the reasoner gives them), then times the reader's filtered ``list`` queries, the ones
``mapr catalog list`` runs (newest first, 50 rows), each the median of 7 runs after one
warm-up. Targets: >= 50 000 events/s batched, < 100 ms per filtered list query.

Each event also opens or updates its fault episode (docs/catalog.md, "Fault episodes"), in
the same transaction. By default every event draws its fault mode afresh (``--persist 1``),
so most events open a new episode and close others: the worst case for episodes. With
``--persist K`` each of the 8 assets keeps its fault mode for K events on average (it
changes with probability 1/K), as a persistent fault found at every BIT does.
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.catalog import CatalogReader, CatalogWriter, Event, EventFilter

T0 = 1_778_300_000_000_000_000
DAY = 86_400_000_000_000
FAULTS = ("esr", "capacitance", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
          "friction", "short", "open")


def make_events(rng: random.Random, n: int, start: int, span_ns: int, persist: float = 1.0,
                current: dict[int, str] | None = None) -> list[Event]:
    """``n`` events; with ``persist`` > 1 each asset keeps its fault (``current``, carried
    from batch to batch) for ``persist`` events on average."""
    out = []
    held = {} if current is None else current
    for k in range(n):
        if persist <= 1.0:
            fault = rng.choice(FAULTS)
            unit = None
        else:
            unit = rng.randint(1, 8)
            if unit not in held or rng.random() < 1.0 / persist:
                held[unit] = rng.choice(FAULTS)
            fault = held[unit]
        terminal = fault in ("short", "open")
        sev = None if terminal else rng.random()
        out.append(Event(
            t_ns=T0 + (start + k) * span_ns,
            asset=f"EMA{rng.randint(1, 8) if unit is None else unit}", rt=5,
            fault=fault, switch="A_high" if terminal else None, severity=sev,
            severity_value=None if sev is None else 0.05 + sev, severity_unit="ohm",
            confidence=rng.random(), soh=rng.random(), rul=rng.uniform(0, 500),
            rul_low=10.0, rul_high=600.0, rul_unit="flights",
            params={"esr_ohm": rng.random(), "capacitance_f": 2.88e-4, "ron_ohm": 0.2},
            evidence={"score": rng.random() * 10, "threshold": 1.0,
                      "severity_fraction_of_range": sev}))
    return out


def timed(query: Callable[[], object], repeats: int = 7) -> float:
    query()
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        query()
        runs.append(time.perf_counter() - t)
    return statistics.median(runs)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--events", type=int, default=1_000_000)
    ap.add_argument("--batch", type=int, default=5000)
    ap.add_argument("--durability", choices=["power-loss", "crash"], default="power-loss")
    ap.add_argument("--persist", type=float, default=1.0,
                    help="events an asset keeps its fault mode for, on average (1: none)")
    args = ap.parse_args()
    rng = random.Random(1553)
    span = 30 * DAY // args.events  # a month of events
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "catalog.sqlite"
        insert_s = 0.0
        with CatalogWriter(path, durability=args.durability) as writer:
            writer.open_session(backend="bench", config_hash="bench")
            done = 0
            held: dict[int, str] = {}
            while done < args.events:
                batch = make_events(rng, min(args.batch, args.events - done), done, span,
                                    args.persist, held)
                t = time.perf_counter()
                writer.add_events(batch)  # returns after COMMIT (fsync with power-loss)
                insert_s += time.perf_counter() - t
                done += len(batch)
        size_mb = path.stat().st_size / 1e6
        print(f"catalog bench: {args.events} events, batches of {args.batch}, "
              f"durability={args.durability}, persist={args.persist:g}, "
              f"file {size_mb:.0f} MB")
        print(f"  insert (batched, one transaction per batch): {args.events / insert_s:,.0f} "
              f"events/s  (target >= 50,000)")
        mid = T0 + 15 * DAY
        queries = {
            "list (newest 50, no filter)": EventFilter(),
            "list --asset EMA3": EventFilter(asset="EMA3"),
            "list --fault esr --min-severity 0.8": EventFilter(fault="esr", min_severity=0.8),
            "list --asset EMA3 --since/--until (1 day)":
                EventFilter(asset="EMA3", since_ns=mid, until_ns=mid + DAY),
            "list --asset EMA3 --fault short --min-severity 0.5 --since (7 d)":
                EventFilter(asset="EMA3", fault="short", min_severity=0.5,
                            since_ns=mid, until_ns=mid + 7 * DAY),
            "list --min-severity 0.99": EventFilter(min_severity=0.99),
        }
        worst = 0.0
        with CatalogReader(path) as reader:
            print(f"  fault episodes: {len(reader.episodes())} for {args.events} events "
                  f"(seed 1553)")
            for name, flt in queries.items():
                s = timed(lambda flt=flt: reader.events(flt, limit=50))
                worst = max(worst, s)
                print(f"  {name:<66} {s * 1e3:7.2f} ms")
            s = timed(lambda: reader.event(args.events // 2), repeats=7)
            print(f"  {'show ID':<66} {s * 1e3:7.2f} ms")
        print(f"  slowest filtered list query: {worst * 1e3:.2f} ms  (target < 100 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
