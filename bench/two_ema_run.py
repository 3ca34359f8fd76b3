"""``mapr run`` on the two-actuator testbed, recorded, then ``mapr replay`` of its recording.

The daemon runs ``configs/mapr-two-ema.yaml`` (the aileron EMA1 at RT 5, 2 kHz, and the
elevator EMA2 at RT 7, 1 kHz, on one loopback bus; each requested a BIT every 2 s of bus
time) with its dictionaries and prognostic models filled in, ``realtime: false``, a bus-time
duration, one seeded fault (default ``esr=0.6`` on EMA2, the config's) and recording on.
When the testbed's stream ends the daemon is stopped (SIGTERM). Read back from its catalog:
the open fault episodes per actuator, each actuator's SoH and RUL (or why none) after its
last BIT (``bits`` table), and the events' bus-time stamps. Then ``mapr replay`` of the
recording, with the same config, into a second catalog: its events are compared with the
daemon's on (asset, fault, bus_ns). Prints everything; exits 1 if a check fails.

Models: the dictionary and the full prognostic model per actuator type at its bus rate that
``mapr demo`` uses (its smaller dictionary spec, ``configs/reasoner/dictionary-demo.yaml``:
the pre-built pair shipped in ``mapr_daemon/testbed/models/`` when it matches the code, else
built once into ``$MAPR_CACHE``), or ``--models DIR`` holding
``{aileron,elevator}-{dictionary,prognosis}.npz``. Seeds: fresh (printed): EMA1 flies seed s,
EMA2 s + 1.

    python3 bench/two_ema_run.py [--seconds 600] [--seed N] [--fault esr=0.6]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.seeds import fresh
from mapr_daemon.catalog import CatalogReader

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "mapr-two-ema.yaml"
RATES = {"EMA1": 2000.0, "EMA2": 1000.0}
"""Each asset's block rate on the two-EMA table (its dictionary's and model's rate)."""


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What one daemon run and its replay gave."""

    live: list[tuple[str, str | None, int | None]]
    """The daemon's events: (asset, fault, bus_ns), in bus-time order."""
    replayed: list[tuple[str, str | None, int | None]]
    open_episodes: dict[str, list[str]]
    """Asset -> the modes of its open episodes (the daemon's catalog)."""
    replay_episodes: dict[str, list[str]]
    bits: dict[str, int]
    """BITs in each asset's history (the daemon's catalog)."""
    health: dict[str, str]
    """Asset -> its SoH and RUL (or note) after its last BIT, as stored in ``bits``."""
    wall_s: float
    """Wall time of the daemon run."""


def cached_models(asset: str, actuator: Path) -> tuple[Path, Path]:
    """``mapr demo``'s cached dictionary and prognostic model for this actuator at its rate."""
    from mapr_daemon.ema.params import load_actuator, with_sample_rate
    from mapr_daemon.testbed.demo_reasoner import cached_models as cached
    return cached(with_sample_rate(load_actuator(actuator), RATES[asset]), actuator)


def write_config(work: Path, seconds: float, seed: int, fault: str | None,
                 models: dict[str, tuple[Path, Path]]) -> Path:
    """``configs/mapr-two-ema.yaml`` with absolute paths, the models, the run's settings."""
    conf: dict[str, Any] = yaml.safe_load(CONFIG.read_text(encoding="utf-8"))
    here = CONFIG.parent
    conf["icd"] = str(here / conf["icd"])
    testbed = conf["testbed"]
    testbed.update(realtime=False, duration_s=seconds)
    for k, flown in enumerate(testbed["actuators"]):
        flown["actuator"] = str(here / flown["actuator"])
        flown["seed"] = seed + k
        flown["fault"] = fault if flown["name"] == "EMA2" else None
    for asset in conf["assets"]:
        asset["actuator"] = str(here / asset["actuator"])
        asset["dictionary"], asset["prognosis"] = map(str, models[asset["name"]])
    conf["catalog"] = {"path": str(work / "daemon.sqlite")}
    conf["record"] = {"path": str(work / "recordings")}
    path = work / "mapr-two-ema.yaml"
    path.write_text(yaml.safe_dump(conf, sort_keys=False), encoding="utf-8")
    return path


def run_daemon(config: Path, log: Path, timeout_s: float) -> float:
    """``mapr run`` until its testbed stream ends, then SIGTERM; its wall time."""
    started = time.monotonic()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("NOTIFY_SOCKET", None)
    with log.open("wb") as err:
        proc = subprocess.Popen([sys.executable, "-m", "mapr_daemon.cli.main", "run",
                                 "--config", str(config)], cwd=ROOT, env=env,
                                stdout=subprocess.DEVNULL, stderr=err)
        try:
            while "stream ended" not in log.read_text(errors="replace"):
                if proc.poll() is not None:
                    raise RuntimeError(f"mapr run exited {proc.returncode}:\n"
                                       f"{log.read_text(errors='replace')}")
                if time.monotonic() - started > timeout_s:
                    raise RuntimeError(f"mapr run: no end of stream in {timeout_s:.0f} s")
                time.sleep(0.5)
            wall = time.monotonic() - started
            proc.send_signal(signal.SIGTERM)
            if proc.wait(timeout=60) != 0:
                raise RuntimeError(f"mapr run exited {proc.returncode} on SIGTERM")
            return wall
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def replay(config: Path, recording: Path, catalog: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "replay",
                           str(recording), "--config", str(config), "--diagnose", "--catalog",
                           str(catalog), "--no-progress"], cwd=ROOT, capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise RuntimeError(f"mapr replay exited {done.returncode}: {done.stderr}")


def read(catalog: Path) -> tuple[list[tuple[str, str | None, int | None]],
                                 dict[str, list[str]], dict[str, int], dict[str, str]]:
    """Events (asset, fault, bus_ns), open episodes' modes, BIT counts, last health."""
    from mapr_daemon.views.health import fmt_rul, fmt_soh
    with CatalogReader(catalog) as reader:
        events = sorted(((e.asset, e.fault, e.bus_ns) for e in reader.events()),
                        key=lambda e: (e[2] or 0, e[0]))
        episodes: dict[str, list[str]] = {a: [] for a in RATES}
        for ep in reader.episodes(open_only=True):
            episodes.setdefault(ep.asset, []).extend(ep.modes)
        history = reader.bits()
    counts = {a: sum(1 for b in history if b.asset == a) for a in RATES}
    health = {}
    for a in RATES:
        mine = [b for b in history if b.asset == a]
        if mine:
            h = mine[-1].health
            health[a] = f"SoH {fmt_soh(h)}, mode {h.mode or '-'}, RUL {fmt_rul(h)}"
    return events, episodes, counts, health


def run(work: Path, seconds: float, seed: int, fault: str | None,
        models: dict[str, tuple[Path, Path]], timeout_s: float = 3600.0) -> Outcome:
    """One daemon run of ``seconds`` of bus time and the replay of its recording."""
    config = write_config(work, seconds, seed, fault, models)
    wall = run_daemon(config, work / "daemon.log", timeout_s)
    (recording,) = (work / "recordings").iterdir()
    replay(config, recording, work / "replayed.sqlite")
    live, episodes, bits, health = read(work / "daemon.sqlite")
    replayed, replay_episodes, _, _ = read(work / "replayed.sqlite")
    return Outcome(live, replayed, episodes, replay_episodes, bits, health, wall)


def report(o: Outcome, fault: str | None) -> list[str]:
    """Print the run and the comparison; the checks that failed."""
    failed = []
    for asset in RATES:
        print(f"{asset}: {o.bits[asset]} BITs; open episodes {o.open_episodes[asset] or 'none'}"
              f"; last BIT's health: {o.health.get(asset, 'none stored')}")
    want = {"EMA1": 0, "EMA2": 1 if fault else 0}
    for asset, n in want.items():
        if len(o.open_episodes[asset]) != n:
            failed.append(f"{asset}: {len(o.open_episodes[asset])} open episodes, want {n}")
        if asset not in o.health:
            failed.append(f"{asset}: no SoH/RUL in the bits table")
    if any(bus is None for _, _, bus in o.live):
        failed.append("an event without its bus time")
    same = o.live == o.replayed
    print(f"events: daemon {len(o.live)}, replay {len(o.replayed)}; identical on "
          f"(asset, fault, bus_ns): {same}")
    for asset in RATES:
        mine = [(f, b) for a, f, b in o.live if a == asset]
        if mine:
            print(f"  {asset}: {len(mine)} events, faults {sorted({str(f) for f, _ in mine})},"
                  f" bus time {(mine[0][1] or 0) / 1e9:.3f}..{(mine[-1][1] or 0) / 1e9:.3f} s")
    for (a, f, b), (ra, rf, rb) in zip(o.live, o.replayed, strict=False):
        if (a, f, b) != (ra, rf, rb):
            print(f"  first difference: daemon {(a, f, b)} vs replay {(ra, rf, rb)}")
            break
    if not same:
        failed.append("the replay's events differ from the daemon's")
    if o.replay_episodes != o.open_episodes:
        failed.append(f"open episodes differ: replay {o.replay_episodes}")
    print(f"open episodes after the replay: {o.replay_episodes}")
    return failed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=600.0, help="bus time (default 600)")
    parser.add_argument("--seed", type=int)
    parser.add_argument("--fault", default="esr=0.6", help="EMA2's fault ('none': healthy)")
    parser.add_argument("--models", type=Path, metavar="DIR",
                        help="{aileron,elevator}-{dictionary,prognosis}.npz (default: cached)")
    parser.add_argument("--keep", type=Path, metavar="DIR", help="work here and keep it")
    args = parser.parse_args()
    seed = fresh(args.seed)
    fault = None if args.fault == "none" else args.fault
    actuators = CONFIG.parent / "actuators"
    models: dict[str, tuple[Path, Path]] = {}
    for asset, surface in (("EMA1", "aileron"), ("EMA2", "elevator")):
        if args.models:
            models[asset] = (args.models / f"{surface}-dictionary.npz",
                             args.models / f"{surface}-prognosis.npz")
        else:
            models[asset] = cached_models(asset, actuators / f"{surface}-uav.yaml")
    print(f"two-EMA testbed: {args.seconds:g} s of bus time, EMA1 (aileron, 2 kHz) healthy "
          f"seed {seed}, EMA2 (elevator, 1 kHz) {fault or 'healthy'} seed {seed + 1}; "
          "a BIT every 2 s each")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        outcome = run(work, args.seconds, seed, fault, models)
    print(f"mapr run: {outcome.wall_s:.0f} s wall for {args.seconds:g} s of bus time")
    failed = report(outcome, fault)
    for line in failed:
        print(f"FAILED: {line}")
    print("all checks passed" if not failed else f"{len(failed)} checks failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
