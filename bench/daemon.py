"""Keeping up with a fully loaded bus: the daemon's pipeline against the bus's message rate.

    python bench/daemon.py [--seconds 10] [--dictionary dictionary.npz] [--queue-batches 256]

1. Records ``--seconds`` of the testbed aircraft's bus with filler traffic (``testbed.fill_bus``:
   ~93 % bus load, the BIT flown every 2 s) to a Chapter 10 file. The simulated aircraft is
   slower than real time on a small machine, so the bus is recorded first and not timed.
2. Runs the daemon on that recording — :class:`~mapr_daemon.service.service.Service`, the
   object ``mapr run`` runs, in this process's main thread: backend ``chapter10`` -> bus
   reader thread -> bounded queue -> ICD -> BIT watcher and reasoner -> SQLite catalog — twice:

   * ``paced``: the recording replayed in its own time (``speed: 1.0``), as the bus comes.
     Processed messages per wall second against the bus's messages per bus second: 1.0 keeps
     up. The queue's peak says how close it came to dropping work.
   * ``unpaced``: as fast as the file reads (``speed: 0``): the most messages per second the
     pipeline gets through, divided by the bus rate, is the headroom. The replay thread
     competes with the pipeline for the interpreter, so this is a lower bound.

   Each run is timed from the first message decoded (READY) to the end of the source; the
   bench then sends itself SIGTERM, as systemd would. Figures are per run; ``busy`` is the
   main loop's share of that wall time spent on queued work. A small dictionary is built
   first when none is given (~20 s).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.chapter10.writer import Chapter10Writer
from mapr_daemon.icd import load_icd
from mapr_daemon.service import logs
from mapr_daemon.service.config import (
    BackendConfig,
    CatalogConfig,
    Config,
    ReasonerConfig,
)
from mapr_daemon.service.notify import Notifier
from mapr_daemon.service.service import Service
from mapr_daemon.service.source import monitor_factory

ROOT = Path(__file__).resolve().parents[1]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


def load_average() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def small_dictionary(folder: Path) -> Path:
    """The tests' small dictionary (healthy, ESR, friction, phase-A high-side short/open)."""
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training import dictionary_build

    spec = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=4,
                          severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr", "friction"),
                          shorts=("A_high",), opens=("A_high",), calibration_runs=10,
                          calibration_pressure_pa=(200.0, 1400.0), threshold_margin=1.5)
    path = folder / "dictionary.npz"
    dictionary_build.build(load_actuator(default_actuator_path()), spec).save(path)
    return path


def record_bus(path: Path, seconds: float) -> tuple[int, float, float]:
    """Fly the testbed with filler traffic for ``seconds`` of bus time into ``path``;
    returns (messages, bus seconds, bus load %)."""
    config = Config(icd=str(ICD), testbed=dict(realtime=False, duration_s=seconds,
                                                        fill_bus=True, fault="open=A_high"))
    messages, first, last = 0, None, 0
    with monitor_factory(config, load_icd(ICD))() as monitor, Chapter10Writer(path) as writer:
        for record in monitor:
            writer.write([record])
            messages += 1
            first = record.t_ns if first is None else first
            last = record.end_ns
        load = max(monitor.stats.load(bus) for bus in monitor.stats.messages)
    return messages, (last - (first or 0)) / 1e9, load


def run_daemon(recording: Path, catalog: Path, dictionary: Path, speed: float,
               queue_batches: int) -> dict[str, float]:
    """One daemon run on the recording until its end; the figures of that run."""
    config = Config(backend=BackendConfig(name="chapter10",
                                          options={"path": str(recording), "speed": speed}),
                    icd=str(ICD), reasoner=ReasonerConfig(dictionary=str(dictionary)),
                    catalog=CatalogConfig(path=str(catalog), stats_interval_s=1.0),
                    queue_batches=queue_batches)
    service = Service(config, None, Notifier(None))
    ended: dict[str, float] = {}

    def stop_at_the_end() -> None:
        while not service.ready:
            time.sleep(0.005)
        ready = time.monotonic()   # the first message decoded: the bus is flowing
        while service.state != "stream ended, idle":
            time.sleep(0.02)
        ended["wall_s"] = time.monotonic() - ready
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=stop_at_the_end, daemon=True).start()
    assert service.run() == 0
    return {"messages": service.messages, "wall_s": ended["wall_s"], "busy_s": service.busy_s,
            "queue_peak": service.queue_peak, "dropped": service.dropped,
            "events": service.events}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=10.0, help="bus time recorded")
    parser.add_argument("--dictionary", type=Path, help="fault dictionary (default: build one)")
    parser.add_argument("--queue-batches", type=int, default=256)
    args = parser.parse_args()
    logs.setup("error")
    print(f"machine: {os.cpu_count()} cores, load average {load_average()}")
    with tempfile.TemporaryDirectory(prefix="mapr-bench-") as tmp:
        folder = Path(tmp)
        dictionary = args.dictionary or small_dictionary(folder)
        recording = folder / "loaded.ch10"
        messages, bus_s, load = record_bus(recording, args.seconds)
        bus_rate = messages / bus_s
        print(f"bus: {messages} messages in {bus_s:.2f} s of bus time = {bus_rate:.0f} msg/s, "
              f"load {load:.1f} % (testbed + filler, seeded open=A_high, BIT every 2 s)")
        print(f"{'run':<8} {'processed msg/s':>15} {'bus msg/s':>9} {'ratio':>6} {'busy':>6} "
              f"{'queue peak':>11} {'dropped':>7} {'events':>6}  load average")
        for name, speed in (("paced", 1.0), ("unpaced", 0.0)):
            figures = run_daemon(recording, folder / f"{name}.sqlite", dictionary, speed,
                                 args.queue_batches)
            rate = figures["messages"] / figures["wall_s"]
            print(f"{name:<8} {rate:>15.0f} {bus_rate:>9.0f} {rate / bus_rate:>6.2f} "
                  f"{100 * figures['busy_s'] / figures['wall_s']:>5.0f}% "
                  f"{figures['queue_peak']:>5.0f}/{args.queue_batches:<5} "
                  f"{figures['dropped']:>7.0f} {figures['events']:>6.0f}  {load_average()}")
            if figures["messages"] != messages:
                print(f"  note: {figures['messages']} of {messages} messages processed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
