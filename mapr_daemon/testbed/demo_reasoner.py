"""The demo's reasoner: the fault dictionary (built once, then cached) and the BIT diagnosis.

``mapr demo`` must run on a fresh machine with nothing but the package, so when no
``--dictionary`` is given it builds one from the shipped spec
(``configs/reasoner/dictionary.yaml``) and keeps it in the user's cache directory
(``$MAPR_CACHE``, else ``$XDG_CACHE_HOME/mapr``, else ``~/.cache/mapr``). The cache key
is a hash of the spec, the actuator file, the sample rate it is built at and the source of
every module the dictionary's content depends on (the plant, the profiles, the reasoner), so
a changed model is never diagnosed with a stale dictionary. The actuator's prognostic model
(what SoH trends and RUL need, :mod:`mapr_daemon.reasoner.prognosis.prognostic_model`) is built
from that
dictionary and cached beside it under the same key.
"""

from __future__ import annotations

import hashlib
import os
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.cli.commands.dictionary import default_spec_path, peak_rss_mb
from mapr_daemon.ema.params import ActuatorParams, load_actuator
from mapr_daemon.findings import Diagnosis
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Batch, build_pipeline
from mapr_daemon.pipeline.settings import ReasonerConfig
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
from mapr_daemon.reasoner.training.dictionary_build import build
from mapr_daemon.service.config import Config

PACKAGE = Path(__file__).resolve().parents[1]
MODEL_SOURCES = ("ema", "reasoner", "testbed")
"""Packages whose source decides what a dictionary holds."""


def cache_dir() -> Path:
    explicit = os.environ.get("MAPR_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mapr"


def dictionary_key(spec_path: Path, actuator_path: Path, sample_rate_hz: float | None = None
                   ) -> str:
    """A digest of everything a built dictionary depends on (``sample_rate_hz``: the rate it
    is built at, when not the actuator file's)."""
    digest = hashlib.sha256()
    if sample_rate_hz is not None:
        digest.update(f"rate={sample_rate_hz:.6g}".encode())
    sources = [spec_path, actuator_path]
    for package in MODEL_SOURCES:
        sources += sorted((PACKAGE / package).rglob("*.py"))
    for source in sources:
        digest.update(source.name.encode())
        digest.update(source.read_bytes())
    return digest.hexdigest()[:16]


def cached_dictionary(params: ActuatorParams, actuator_path: Path,
                      spec_path: Path | None = None) -> Path:
    """The cached dictionary for this model, built (with progress on stderr) if missing."""
    spec_path = spec_path or default_spec_path()
    path = cache_dir() / f"dictionary-{cache_key(params, actuator_path, spec_path)}.npz"
    if path.exists():
        return path
    spec = DictionarySpec.load(spec_path)
    print(f"Building the {params.name} fault dictionary at "
          f"{params.sensors.sample_rate_hz:g} Hz once ({spec_path.name}; under a minute); "
          f"it is cached in {path.parent}", file=sys.stderr)
    started = time.monotonic()

    tty = sys.stderr.isatty()
    shown = [-1]

    def progress(fraction: float) -> None:
        # a terminal gets a line redrawn at every whole percent, a log one line per tenth
        step = int(100 * fraction) if tty else 10 * int(10 * fraction)
        if step == shown[0]:
            return
        shown[0] = step
        print(f"\r  simulating fault-seeded BITs: {step:3d} %", end="" if tty else "\n",
              file=sys.stderr, flush=True)

    dictionary = build(params, spec, progress=progress)
    print(f"\r  built in {time.monotonic() - started:.0f} s (peak memory {peak_rss_mb():.0f} MB)"
          f"{' ' * 10}", file=sys.stderr)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".partial.npz")
    dictionary.save(partial)
    partial.replace(path)   # atomic: a killed build never leaves a half file under the key
    return path


def cache_key(params: ActuatorParams, actuator_path: Path, spec_path: Path) -> str:
    """The cache key of this actuator type's dictionary and model at ``params``' rate; the
    file's own rate keeps the key it always had."""
    rate = params.sensors.sample_rate_hz
    own = load_actuator(actuator_path).sensors.sample_rate_hz
    return dictionary_key(spec_path, actuator_path, None if rate == own else rate)


def cached_models(params: ActuatorParams, actuator_path: Path,
                  spec_path: Path | None = None) -> tuple[Path, Path]:
    """The cached dictionary and prognostic model of this actuator type at ``params``'
    sample rate, each built (progress on stderr) if missing."""
    spec_path = spec_path or default_spec_path()
    dictionary = cached_dictionary(params, actuator_path, spec_path)
    path = cache_dir() / f"prognosis-{cache_key(params, actuator_path, spec_path)}.npz"
    if path.exists():
        return dictionary, path
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.prognosis_build import build_prognostic_model
    print(f"Building the {params.name} prognostic model once (degradation estimators, their "
          f"noise, fleet priors; about a minute); it is cached in {path.parent}",
          file=sys.stderr)
    started = time.monotonic()
    model = build_prognostic_model(Dictionary.load(dictionary), params)
    print(f"  built in {time.monotonic() - started:.0f} s", file=sys.stderr)
    partial = path.with_suffix(".partial.npz")
    model.save(partial)
    partial.replace(path)
    return dictionary, path


def diagnose_bits(icd_path: str | Path, records: Sequence[MonitorRecord],
                  dictionary_path: Path) -> Batch:
    """Every BIT in the traffic, cut out, decided and stamped by the daemon's own path
    (:mod:`mapr_daemon.pipeline.pipeline`, the default asset: EMA1 on RT 5, the shipped
    actuator file and wiring)."""
    config = Config(icd=str(icd_path), reasoner=ReasonerConfig(dictionary=str(dictionary_path)))
    return build_pipeline(config).process(list(records), BusClock())


def describe(diagnosis: Diagnosis) -> Iterable[str]:
    """A maintainer's reading of one diagnosis."""
    evidence = diagnosis.evidence
    at = evidence.get("bit_bus_time_s")
    head = f"BIT at bus time {at:.3f} s" if isinstance(at, float) else "BIT"
    if not diagnosis.anomaly:
        yield (f"{head}: nominal (score {evidence.get('score', 0):.0f} below threshold "
               f"{evidence.get('threshold', 0):.0f})")
        return
    switch = diagnosis.switch
    fault = f"{diagnosis.fault}/{switch}" if switch else str(diagnosis.fault)
    severity = diagnosis.severity
    amount = "" if severity is None else f", severity {severity:.4g} {diagnosis.unit or ''}"
    soh = 1.0 if diagnosis.soh is None else diagnosis.soh
    yield (f"{head}: ANOMALY {fault}{amount}, confidence {diagnosis.confidence:.2f}, "
           f"state of health {soh:.2f} ({diagnosis.component or ''})")
    yield (f"    score {evidence.get('score', 0):.0f} vs threshold "
           f"{evidence.get('threshold', 0):.0f}")
