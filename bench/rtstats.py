"""Speed of the per-RT/SA statistics: records per second through TrafficStatistics.add_batch
(arrays built once per batch, then numpy), beside the per-record BusStatistics.add the
monitor already runs, on random traffic (random RT/SA/T-R/word counts, 1 % errors, 1 % RT-RT,
2 % mode codes). Prints the seed, the batch size and the best and worst of the repeats.

    python3 bench/rtstats.py [--seed N] [--records 200000] [--batch 4096] [--repeats 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.seeds import fresh
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.monitor import BusStatistics
from drivers.rtstats import TrafficStatistics


def traffic(rng: np.random.Generator, n: int) -> list[MonitorRecord]:
    out = []
    t = 0
    for _ in range(n):
        rt, sa, wc = int(rng.integers(0, 31)), int(rng.integers(1, 31)), int(rng.integers(1, 33))
        tr = int(rng.integers(0, 2))
        kind = rng.random()
        t += int(rng.integers(20_000, 800_000))
        gap = int(rng.integers(4000, 12000))
        errors = ("no_response",) if rng.random() < 0.01 else ()
        if kind < 0.02:
            out.append(MonitorRecord(t, "A", TransferFormat.MODE, rt << 11 | 1 << 10 | 2,
                                     status=(rt << 11,), gaps_ns=(gap,), errors=errors))
        elif kind < 0.03:
            out.append(MonitorRecord(t, "B", TransferFormat.RT_RT, rt << 11 | sa << 5 | wc % 32,
                                     command2=(rt + 1) % 31 << 11 | 1 << 10 | sa << 5 | wc % 32,
                                     data=(0,) * wc, status=(0, 0), gaps_ns=(gap, gap + 100),
                                     errors=errors))
        else:
            out.append(MonitorRecord(t, "AB"[tr], TransferFormat.RT_BC if tr else
                                     TransferFormat.BC_RT, rt << 11 | tr << 10 | sa << 5 | wc % 32,
                                     data=(0,) * wc, status=(rt << 11,), gaps_ns=(gap,),
                                     errors=errors))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int)
    parser.add_argument("--records", type=int, default=200_000)
    parser.add_argument("--batch", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(fresh(args.seed))
    records = traffic(rng, args.records)
    batches = [records[k:k + args.batch] for k in range(0, len(records), args.batch)]
    print(f"{len(records)} records in batches of {args.batch}, {args.repeats} repeats")
    for name, run in (("TrafficStatistics.add_batch", _per_rt_sa),
                      ("BusStatistics.add (per record)", _per_bus)):
        rates = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            run(batches)
            rates.append(len(records) / (time.perf_counter() - start))
        print(f"{name:<32} best {max(rates) / 1e3:8.0f} k records/s, "
              f"worst {min(rates) / 1e3:8.0f} k records/s")


def _per_rt_sa(batches: list[list[MonitorRecord]]) -> None:
    stats = TrafficStatistics()
    for batch in batches:
        stats.add_batch(batch)
    stats.rows()


def _per_bus(batches: list[list[MonitorRecord]]) -> None:
    stats = BusStatistics()
    for batch in batches:
        for record in batch:
            stats.add(record)


if __name__ == "__main__":
    main()
