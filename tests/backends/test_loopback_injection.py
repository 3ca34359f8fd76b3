"""Every error the loopback bus can inject is caught and named by the monitor (bit level)."""

from __future__ import annotations

from typing import Any

import pytest

from drivers.backends.loopback import (
    EXPECTED_ERRORS,
    INJECTION_KINDS,
    Injection,
    ScheduledMessage,
    bc_rt,
    default_schedule,
    rt_bc,
    rt_rt,
)
from drivers.backends.loopback.backend import LoopbackMonitor
from drivers.mil1553.encoder import Impairments

from .conftest import Runner, terminal

WORD = {"word_error"}
# (kind, injection options, message, errors of the first record, buses of the records)
CASES: list[tuple[str, dict[str, Any], ScheduledMessage, set[str], str]] = [
    ("parity", {}, rt_bc(5, 3, 3), {"parity"} | WORD, "A"),
    ("parity", {"word": 0}, rt_bc(5, 3, 3), {"parity", "no_response"} | WORD, "AB"),
    ("parity", {"word": 1}, bc_rt(5, 2, 2), {"parity", "no_response"} | WORD, "AB"),
    ("parity", {"word": 1}, rt_bc(5, 3, 3), {"parity"} | WORD, "AB"),
    ("manchester", {}, rt_bc(5, 3, 3), {"manchester"} | WORD, "A"),
    ("manchester", {"word": 2}, bc_rt(5, 2, 2), {"manchester", "no_response"} | WORD, "AB"),
    ("bit_count_low", {}, rt_bc(5, 3, 3), {"bit_count_low"} | WORD, "A"),
    ("bit_count_high", {}, rt_bc(5, 3, 3), {"bit_count_high"} | WORD, "A"),
    ("bit_count_high", {"word": 0}, bc_rt(5, 2, 2),
     {"bit_count_high", "no_response"} | WORD, "AB"),
    ("sync", {}, rt_bc(5, 3, 3), {"sync"}, "A"),
    ("sync", {"word": 1}, bc_rt(5, 2, 2), {"sync", "no_response"}, "AB"),
    ("no_response", {}, rt_bc(5, 3, 3), {"no_response"}, "AB"),
    ("no_response", {}, bc_rt(5, 3, 3), {"no_response"}, "AB"),
    ("late_response", {}, rt_bc(5, 3, 3), {"late_response"}, "A"),
    ("late_response", {"gap_ns": 12_500}, bc_rt(5, 3, 3), {"late_response"}, "A"),
    ("early_response", {}, rt_bc(5, 3, 3), {"early_response"}, "A"),
    ("early_response", {"responder": 1}, rt_rt(6, 3, 5, 3, 3), {"early_response"}, "A"),
    ("word_count_low", {}, rt_bc(5, 3, 3), {"word_count_low"}, "A"),
    ("word_count_high", {}, rt_bc(5, 3, 3), {"word_count_high"}, "A"),
    ("word_count_low", {}, bc_rt(5, 3, 3), {"word_count_low", "no_response"}, "AB"),
    ("word_count_high", {}, bc_rt(5, 3, 3), {"word_count_high", "no_response"}, "AB"),
    ("word_count_low", {}, rt_rt(6, 3, 5, 3, 3), {"word_count_low", "no_response"}, "AB"),
    ("babbling", {}, rt_bc(5, 3, 3), {"babbling", "word_count_high"}, "A"),
    ("noise", {}, rt_bc(5, 3, 3), {"orphan_words", "sync"} | WORD, "AA"),
    ("wrong_rt_address", {}, rt_bc(5, 3, 3), {"wrong_rt_address"}, "A"),
    ("reserved_status_bits", {}, bc_rt(5, 3, 3), {"reserved_status_bits"}, "A"),
    ("superseded", {}, bc_rt(5, 4, 4), {"superseded", "word_count_low"}, "AA"),
]


@pytest.mark.parametrize(("kind", "options", "message", "errors", "buses"), CASES,
                         ids=[f"{c[0]}-{c[2].label}-{c[1]}" for c in CASES])
def test_injected_error_is_detected_and_named(run_bus: Runner, kind: str,
                                              options: dict[str, Any],
                                              message: ScheduledMessage, errors: set[str],
                                              buses: str) -> None:
    records, monitor = run_bus([message], injections=[Injection(kind, **options)],
                               frame_ns=1_500_000)
    assert set(records[0].errors) == errors, records[0].to_json()
    assert EXPECTED_ERRORS[kind] in records[0].errors
    assert "".join(r.bus for r in records) == buses
    assert all(r.errors == () for r in records[1:]), "the retry / next message is clean"
    assert monitor.controller.injector.pending == [], "a one-shot injection is used up"


def test_every_injection_kind_has_a_case() -> None:
    assert {case[0] for case in CASES} == set(INJECTION_KINDS)


def test_word_level_path_names_errors_alike(run_bus: Runner) -> None:
    for kind, options, message, errors, buses in CASES:
        records, _ = run_bus([message], injections=[Injection(kind, **options)],
                             frame_ns=1_500_000, bit_level=False)
        assert set(records[0].errors) == errors, (kind, records[0].to_json())
        assert "".join(r.bus for r in records) == buses


def test_selector_count_and_forever() -> None:
    monitor = LoopbackMonitor(bit_level=False, frames=50, injections=[
        Injection("late_response", rt=6, sa=1, tr="T", count=3),
        Injection("parity", format="BC_RT", count=None),
    ])
    records = list(monitor)
    late = [r for r in records if "late_response" in r.errors]
    assert len(late) == 3 and all((r.rt, r.sa, r.tr) == (6, 1, "T") for r in late)
    bc_rt_records = [r for r in records if str(r.format) == "BC_RT"]
    assert bc_rt_records and all("parity" in r.errors for r in bc_rt_records)
    others = [r for r in records if r not in late and str(r.format) != "BC_RT"]
    assert others and all(r.errors == () for r in others)


def test_injection_at_run_time_hits_the_next_message() -> None:
    monitor = LoopbackMonitor(bit_level=False, frames=3)
    first = monitor.recv()   # three frames: a record comes, however slow the host
    assert first is not None and first.errors == ()
    monitor.inject(Injection("early_response"))
    records = list(monitor)
    assert next(r for r in records if r.errors).errors == ("early_response",)
    assert sum(1 for r in records if r.errors) == 1


def test_noise_everywhere_and_jitter_are_flagged_without_hiding_messages() -> None:
    monitor = LoopbackMonitor(frames=20, seed=3, impairments=Impairments(jitter_ns=100.0),
                              injections=[Injection("noise", count=None, format="RT_BC")])
    records = list(monitor)
    noise = [r for r in records if str(r.format) == "UNKNOWN"]
    messages = [r for r in records if str(r.format) != "UNKNOWN"]
    sent = [m for k in range(20) for m in default_schedule().frame(k)]
    rt_bc_sent = [m for m in sent if m.transmit and not m.is_mode]
    assert all("sync" in r.errors for r in noise)
    assert all(r.errors == () for r in messages)
    assert (len(messages), len(noise)) == (len(sent), len(rt_bc_sent))


def test_rt_rt_transmitter_word_count_high(run_bus: Runner) -> None:
    records, _ = run_bus([rt_rt(6, 3, 5, 3, 3)], retries=0,
                         injections=[Injection("word_count_high")])
    assert set(records[0].errors) == {"word_count_high", "no_response"}, records[0].to_json()


def test_babbling_counts_the_whole_transmission(run_bus: Runner) -> None:
    rt = terminal(5)
    records, _ = run_bus([rt_bc(5, 30, 30)], terminals=[rt], frame_ns=2_000_000,
                         injections=[Injection("babbling", duration_ns=850_000)])
    assert "babbling" in records[0].errors, records[0].to_json()
