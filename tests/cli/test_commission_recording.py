"""``mapr commission`` from a Chapter 10 recording: the BITs the testbed aircraft flew on the
loopback bus, recorded, cut back out of the traffic and commissioned from; the same BITs
taken from the plant as a ``.npz`` run file give the same identification."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from drivers.backends.loopback import LoopbackMonitor
from drivers.chapter10.writer import Chapter10Writer
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.ema import dataset
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.ema.run import RunResult
from mapr_daemon.icd import load_icd
from mapr_daemon.reasoner.commissioning.bits import BitRecord, condition
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy
from mapr_daemon.reasoner.commissioning.record import read_record
from mapr_daemon.reasoner.commissioning.visibility import Visibility
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import steady_profile

ROOT = Path(__file__).resolve().parents[2]
ICD_PATH = ROOT / "configs" / "icd" / "ema-testbed.yaml"
RATE = 2000.0
BITS = 3
FRAMES = 2900   # 5.8 s of 2 ms minor frames: BITs requested at 0, 2 and 4 s, the last done
START = datetime(2025, 6, 1, 10, 0, 0)


@pytest.fixture(scope="module")
def flown(tmp_path_factory: pytest.TempPathFactory, commission_settings: Path
          ) -> tuple[Path, list[BitRecord]]:
    """A folder with ``bits.c10`` (a healthy testbed flight of :data:`BITS` BITs, recorded)
    and ``bits.npz`` (the same BITs as the EMA sampled them, in ``mapr simulate``'s run
    format), and those BITs as records."""
    d = tmp_path_factory.mktemp("commission-recording")
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE)
    aircraft = Aircraft(load_icd(ICD_PATH), steady_profile(RATE, "cruise"), params, seed=7,
                        bit_requests_s=(0.0,), bit_every_s=2.0)
    ema = aircraft.ema
    ema.history_s = 10.0   # keep every sample the EMA took
    starts: list[int] = []
    receive = ema.receive_bit_request

    def spy(t_ns: int, data: list[int]) -> None:
        """The plant sample each BIT starts at."""
        before = ema.bits_run
        receive(t_ns, data)
        if ema.bits_run > before and ema.bit_start is not None:
            starts.append(ema.bit_start)

    ema.receive_bit_request = spy  # type: ignore[method-assign]
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=FRAMES) as monitor:
        records = list(monitor)
    assert len(starts) == ema.bits_run == BITS and ema.bit_state == "DONE"
    with Chapter10Writer(d / "bits.c10", channel_id=1, start_time=START) as writer:
        writer.write(records)
    profile = bit_profile(RATE, "cruise", params.bit)
    n = profile.n_samples
    channels = {k: np.stack([v[s:s + n] for s in starts]) for k, v in ema.history.items()}
    dataset.save(d / "bits.npz", [RunResult(
        tuple(RunSpec(params, FaultSet(), seed=7) for _ in starts), profile, profile.time_s,
        channels, {})], {"sample_rate_hz": RATE, "actuator": params.name})
    plant = [BitRecord({k: v[i] for k, v in channels.items()}, profile.command_deg,
                       float(profile.dynamic_pressure_pa[0]), RATE, "plant", i)
             for i in range(BITS)]
    for name in ("spec.yaml", "tolerances.yaml"):
        (d / name).write_text((commission_settings / name).read_text())
    return d, plant


def commission(d: Path, out: Path, *inputs: str, dictionary: bool = False) -> int:
    """``mapr commission`` of ``inputs`` into ``out`` with the fast settings, its exit code;
    without ``dictionary``, identification only."""
    return main(["commission", *inputs, "--tolerances", str(d / "tolerances.yaml"), "-o",
                 str(out), *(["--spec", str(d / "spec.yaml")] if dictionary else
                             ["--no-dictionary"])])


def test_the_bits_flown_are_found_in_the_recording_and_commissioned_from(
        flown: tuple[Path, list[BitRecord]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    d, plant = flown
    out = tmp_path / "unit"
    rc = commission(d, out, str(d / "bits.c10"), dictionary=True)
    cap = capsys.readouterr()
    assert rc == exitcodes.OK, cap.err
    assert f"mapr commission: {d / 'bits.c10'}: {BITS} BITs of EMA1 (RT 5) in " in cap.err
    assert f"{BITS} BITs used, 0 skipped" in cap.out
    rec = read_record(out / "commissioning.json")
    # the BITs flown, each once, named by the recording, its index and its time there
    assert [(b.source, b.index, b.label) for b in rec.bits] == \
        [(str(d / "bits.c10"), i, "EMA1") for i in range(BITS)]
    times = [b.time for b in rec.bits]
    assert all(t is not None and t.startswith("2025-06-01T10:00:0") for t in times), times
    assert times == sorted(times)
    # at the conditions they were flown at: the air load, the aircraft bus and the ambient
    # (read over the first 100 ms: the bus carries one temperature sample in 20, so the
    # recording's is a mean of 2 x 10 samples of 0.2 K noise, not 2 x 200: 4 sd is 0.18 K)
    params = load_actuator(default_actuator_path())
    for used, bit in zip(rec.bits, plant, strict=True):
        ambient, bus = condition(params, bit)
        assert used.dynamic_pressure_pa == pytest.approx(bit.dynamic_pressure_pa, rel=1e-3)
        assert used.ambient_c == pytest.approx(ambient, abs=0.18)
        assert used.bus_v == pytest.approx(bus, abs=0.01)
    ident = load_actuator(out / "actuator.yaml")
    assert rec.identified_actuator == "actuator.yaml" and rec.dictionary == "dictionary.npz"
    assert Dictionary.load(out / "dictionary.npz").actuator == ident.name
    # what the identified model still misses on these BITs, learned and saved beside it
    assert rec.discrepancy is not None and rec.discrepancy["file"] == "discrepancy.npz"
    assert Discrepancy.load(out / "discrepancy.npz").bits == BITS
    assert "discrepancy learned" in cap.err and "fit converged in" in cap.out
    # what the unit's BITs can see of each mode its dictionary knows, measured on the
    # calibrated dictionary over the recorded BITs, said and kept
    assert rec.unit_calibration is not None
    seen = Visibility.from_json(rec.unit_calibration["visibility"])
    assert list(seen.detected) == ["esr"] and seen.bits == BITS
    assert not seen.held_out  # three BITs: leaving one out leaves too few to calibrate on
    assert "what this unit's BITs can see" in cap.err and "  esr: seen from" in cap.err
    # three BITs leave two per held-out reading: too few for the detector's tail, said so
    assert rec.detector is None
    assert "no anomaly detector on the baseline: 3 BITs" in cap.err


def test_the_same_bits_as_npz_and_as_recording_identify_the_same_unit(
        flown: tuple[Path, list[BitRecord]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The bus carries each sample to the table's step (1 mA, 1 mV, 1 mdeg): the two
    identifications agree far inside their own sd. Mixed inputs are read in the order given."""
    d, _ = flown
    results = {}
    for name, inputs in (("npz", ["bits.npz"]), ("c10", ["bits.c10"]),
                         ("mixed", ["bits.npz", "bits.c10"])):
        rc = commission(d, tmp_path / name, *(str(d / i) for i in inputs))
        assert rc == exitcodes.OK, capsys.readouterr().err
        results[name] = read_record(tmp_path / name / "commissioning.json")
    npz, c10 = results["npz"].parameters, results["c10"].parameters
    assert [e.path for e in npz] == [e.path for e in c10] == \
        ["motor.back_emf_v_s_per_rad", "motor.inertia_kg_m2"]
    for a, b in zip(npz, c10, strict=True):
        assert b.value == pytest.approx(a.value, rel=max(2.0 * a.sd_rel, 1e-3)), a.path
    mixed = results["mixed"].bits
    assert [(b.source, b.index) for b in mixed] == \
        [(str(d / "bits.npz"), i) for i in range(BITS)] + \
        [(str(d / "bits.c10"), i) for i in range(BITS)]


def test_a_recording_without_a_bit_is_one_line_and_exit_65(
        flown: tuple[Path, list[BitRecord]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    d, _ = flown
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE)
    aircraft = Aircraft(load_icd(ICD_PATH), steady_profile(RATE, "cruise"), params, seed=7)
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=200) as monitor:
        records = list(monitor)
    quiet = tmp_path / "quiet.c10"
    with Chapter10Writer(quiet, channel_id=1, start_time=START) as writer:
        writer.write(records)
    rc = commission(d, tmp_path / "o", str(quiet))
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert rc == exitcodes.DATAERR
    assert line == (f"mapr commission: {quiet}: no BIT to commission from: no BIT of EMA1 "
                    "(RT 5) in the recording (no initiated BIT request in its traffic)")
    # the BITs are on channel 1: reading channel 2 only finds nothing
    rc = commission(d, tmp_path / "o", str(d / "bits.c10"), "--c10-channel", "2")
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert rc == exitcodes.DATAERR and line.startswith(f"mapr commission: {d / 'bits.c10'}: ")
    assert "no 1553 message" in line


def test_a_config_of_several_actuators_needs_asset(
        flown: tuple[Path, list[BitRecord]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    d, _ = flown
    config = tmp_path / "mapr.yaml"
    config.write_text(f"icd: {ROOT / 'configs' / 'icd' / 'ema-testbed-two-ema.yaml'}\n"
                      "assets:\n  - {name: EMA1, rt: 5}\n  - {name: EMA2, rt: 7}\n")
    rc = commission(d, tmp_path / "o", str(d / "bits.c10"), "--config", str(config))
    assert rc == exitcodes.USAGE
    assert capsys.readouterr().err.strip() == (
        "mapr commission: the config watches 2 actuators (EMA1, EMA2): choose one with --asset")
    rc = commission(d, tmp_path / "o", str(d / "bits.c10"), "--config", str(config),
                       "--asset", "EMA9")
    assert rc == exitcodes.USAGE
    assert "--asset EMA9: not an actuator of the config (it has EMA1, EMA2)" in \
        capsys.readouterr().err
