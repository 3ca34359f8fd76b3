"""A real writer process for the kill -9 test: writes batches for ever, printing each id
only after the batch's COMMIT has returned (what the daemon would report as written).

    python writer_proc.py CATALOG SEED
"""

from __future__ import annotations

import random
import sys
import time

from mapr_daemon.catalog import CatalogWriter, Event


def main() -> None:
    path, seed = sys.argv[1], int(sys.argv[2])
    rng = random.Random(seed)
    writer = CatalogWriter(path)  # durability="power-loss": synchronous=FULL
    writer.open_session(backend="loopback", config_hash=f"seed{seed}")
    n = 0
    while True:
        batch = [Event(t_ns=time.time_ns(), asset=f"EMA{rng.randint(1, 3)}", fault="esr",
                       confidence=rng.random(), severity=rng.random(), soh=rng.random(),
                       params={"esr_ohm": rng.random()}, evidence={"seed": seed, "n": n + k})
                 for k in range(rng.randint(1, 200))]
        ids = writer.add_events(batch)
        n += len(ids)
        if rng.random() < 0.2:
            writer.add_stats(time.time_ns() - 10**9, time.time_ns(), {
                "A": {"messages": n, "words": 2 * n, "load_percent": 1.0, "errors": {}}})
        sys.stdout.write(" ".join(map(str, ids)) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
