"""The loopback bus at bit level: every transfer format, every mode code, RT-RT, busy,
message-error silence, status-word reset rules and the A/B retry, as a monitor decodes them."""

from __future__ import annotations

import pytest

from drivers.backends.loopback import Injection, bc_rt, mode, rt_bc, rt_rt
from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.words import StatusWord

from .conftest import Runner, terminal

ME, BCR, BUSY, DBCA, TF = 0x0400, 0x0010, 0x0008, 0x0002, 0x0001


def test_each_transfer_format_is_decoded_as_sent(run_bus: Runner) -> None:
    received: list[tuple[int, tuple[int, ...]]] = []
    rt6 = terminal(6)
    rt6.receive[2] = lambda t_ns, data: received.append((2, data))
    records, _ = run_bus([
        bc_rt(6, 2, 3, data=[0x8000, 0x7FFF, 0x5555]),
        rt_bc(5, 4, 4),
        rt_rt(6, 2, 5, 3, 3),
        mode(5, 1),
        mode(5, 19),
        mode(5, 17, data=[0x1234]),
        bc_rt(31, 2, 2, data=[0xAAAA, 0xFFFF]),
        rt_rt(31, 2, 5, 2, 2),
        mode(31, 1),
        mode(31, 17, data=[0x0042]),
    ], terminals=[terminal(5), rt6])
    formats = [str(r.format) for r in records]
    assert formats == ["BC_RT", "RT_BC", "RT_RT", "MODE", "MODE_TX_DATA", "MODE_RX_DATA",
                       "BCAST_BC_RT", "BCAST_RT_RT", "BCAST_MODE", "BCAST_MODE_RX_DATA"]
    assert all(r.errors == () for r in records), [r.to_json() for r in records]
    bcrt, rtbc, rtrt, _, bit, sync, bcast, bcast_rtrt, _, bcast_sync = records
    assert bcrt.data == (0x8000, 0x7FFF, 0x5555) and bcrt.status == (6 << 11,)
    assert rtbc.data == tuple(4 << 8 | i for i in range(4)) and rtbc.status == (5 << 11,)
    assert (rtrt.rt, rtrt.sa, rtrt.rt2, rtrt.sa2) == (6, 2, 5, 3)
    assert rtrt.status == (5 << 11, 6 << 11) and rtrt.data == (0x300, 0x301, 0x302)
    assert len(rtrt.gaps_ns) == 2
    assert bit.data == (0,) and sync.data == (0x1234,)
    assert bcast.status == () and bcast.data == (0xAAAA, 0xFFFF)
    assert bcast_rtrt.status == (5 << 11,) and bcast_rtrt.data == (0x200, 0x201)
    assert bcast_sync.data == (0x0042,) and bcast_sync.status == ()
    # RT 6 got its BC data, the RT-RT data, and both broadcasts' data.
    assert received == [(2, (0x8000, 0x7FFF, 0x5555)), (2, (0x300, 0x301, 0x302)),
                        (2, (0xAAAA, 0xFFFF)), (2, (0x200, 0x201))]


def test_response_gaps_follow_the_configured_response_time(run_bus: Runner) -> None:
    records, _ = run_bus([rt_bc(5, 2, 2), bc_rt(5, 2, 2)], response_gap_ns=6_000)
    assert all(5_800 <= g <= 6_200 for r in records for g in r.gaps_ns)
    records, _ = run_bus([rt_bc(5, 2, 2)], terminals=[terminal(5, response_gap_ns=11_000)])
    assert 10_800 <= records[0].gaps_ns[0] <= 11_200 and records[0].errors == ()


def _mode_cases() -> list[tuple[int, int, bool]]:
    return [(rt, code, tx) for rt in (5, 31) for code in range(32) for tx in (True, False)]


def test_every_mode_code_legal_illegal_broadcast_or_not(run_bus: Runner) -> None:
    cases = _mode_cases()
    records, _ = run_bus([mode(rt, code, transmit=tx, data=[0x0001])
                          for rt, code, tx in cases], frame_ns=120_000)
    assert len(records) == len(cases)
    previous_illegal = False
    for (rt, code, tx), rec in zip(cases, records, strict=True):
        row = MODE_CODES[code]
        broadcast = rt == 31
        wrong_direction = not row.reserved and row.transmit != tx
        not_broadcastable = broadcast and not row.broadcast_allowed
        illegal = row.reserved or wrong_direction or not_broadcastable
        expected = {"reserved_mode_code"} if row.reserved else set()
        if wrong_direction or not_broadcastable:
            expected.add("illegal_format")
        where = f"RT{rt} MC{code} {'T' if tx else 'R'}: {rec.to_json()}"
        # Legal codes 2 and 18 show the status word of the message before.
        shows_error = previous_illegal if code in (2, 18) and not illegal else illegal
        previous_illegal = illegal
        assert set(rec.errors) == expected, where
        assert rec.mode_code == code and rec.rt == rt, where
        if broadcast:
            assert rec.status == (), where
            continue
        assert len(rec.status) == 1, where
        assert bool(rec.status[0] & ME) == shows_error, where
        rt_data = 1 if tx and row.has_data and not illegal else 0
        bc_data = 1 if not tx and row.has_data else 0
        assert len(rec.data) == rt_data + bc_data, where


def test_transmit_status_and_last_command_keep_the_status_word(run_bus: Runner) -> None:
    records, _ = run_bus([
        bc_rt(31, 2, 2),            # broadcast: sets broadcast received
        mode(5, 2),                 # shows it, without resetting it
        mode(5, 18),                # still shows it; data = the command before
        rt_bc(5, 1, 1),             # any other command resets it
        mode(5, 2),
    ])
    _, status, last, _, after = records
    assert status.status[0] & BCR and last.status[0] & BCR
    assert last.data == (mode(5, 2).commands()[0],)
    assert not after.status[0] & BCR


def test_invalid_data_sets_message_error_and_silence(run_bus: Runner) -> None:
    records, monitor = run_bus([bc_rt(5, 2, 2), mode(5, 2), mode(5, 2)], retries=0,
                               injections=[Injection("parity", rt=5, sa=2, word=2)])
    silent, status, again = records
    assert "no_response" in silent.errors and "parity" in silent.errors
    assert silent.status == ()
    assert status.status[0] & ME, "mode code 2 shows the message error"
    assert status.errors == () and again.status[0] & ME
    assert monitor.terminals[5].message_error


def test_wrong_word_count_from_the_bc_gets_no_status(run_bus: Runner) -> None:
    records, _ = run_bus([bc_rt(5, 2, 2), mode(5, 2)], retries=0,
                         injections=[Injection("word_count_high", rt=5, sa=2)])
    assert records[0].status == () and "no_response" in records[0].errors
    assert records[1].status[0] & ME


def test_illegal_broadcast_sets_message_error_silently(run_bus: Runner) -> None:
    records, _ = run_bus([mode(31, 2), mode(5, 18)])
    assert records[0].status == () and "illegal_format" in records[0].errors
    assert records[1].status[0] & ME and records[1].status[0] & BCR


def test_busy_terminal_answers_status_only(run_bus: Runner) -> None:
    received: list[tuple[int, ...]] = []
    rt = terminal(5)
    rt.busy = True
    rt.receive[2] = lambda t_ns, data: received.append(data)
    records, _ = run_bus([rt_bc(5, 4, 4), bc_rt(5, 2, 2), mode(5, 19)], terminals=[rt])
    tx, rx, bit = records
    assert tx.status[0] & BUSY and tx.data == () and tx.errors == ()
    assert rx.status[0] & BUSY and rx.errors == ()
    assert received == [], "a busy terminal discards received data"
    assert bit.data == (0,), "mode codes are answered while busy"


def test_status_flags_and_terminal_flag_inhibit(run_bus: Runner) -> None:
    rt = terminal(5, accepts_bus_control=True)
    rt.terminal_flag = rt.service_request = rt.subsystem_flag = rt.instrumentation = True
    records, _ = run_bus([rt_bc(5, 1, 1), mode(5, 6), rt_bc(5, 1, 1), mode(5, 7),
                          rt_bc(5, 1, 1), mode(5, 0)], terminals=[rt])
    first = StatusWord.from_value(records[0].status[0])
    assert first.flags == ("instrumentation", "service_request", "subsystem_flag",
                           "terminal_flag")
    assert not records[2].status[0] & TF, "inhibited"
    assert records[4].status[0] & TF, "restored"
    assert records[5].status[0] & DBCA
    records, _ = run_bus([mode(5, 0)])
    assert not records[0].status[0] & DBCA, "DBCA clear unless the terminal accepts"


def test_transmitter_shutdown_and_override(run_bus: Runner) -> None:
    records, monitor = run_bus([mode(5, 4), rt_bc(5, 1, 1, bus=1), mode(5, 5),
                                rt_bc(5, 1, 1, bus=1)], retries=0)
    assert [r.bus for r in records] == ["A", "B", "A", "B"]
    assert "no_response" in records[1].errors
    assert records[3].errors == ()
    assert monitor.terminals[5].shutdown == set()


def test_reset_mode_code_restores_the_transmitter(run_bus: Runner) -> None:
    records, monitor = run_bus([mode(31, 4), mode(5, 8), rt_bc(5, 1, 1, bus=1)], retries=0)
    assert records[2].errors == ()
    assert monitor.terminals[5].resets == 1 and monitor.terminals[6].shutdown == {1}


def test_vector_bit_word_and_selected_shutdown(run_bus: Runner) -> None:
    rt = terminal(5, vector=0x0ABC, bit_word=lambda t_ns: 0x0F0F)
    records, monitor = run_bus([mode(5, 16), mode(5, 19), mode(5, 20, data=[3])],
                               terminals=[rt])
    assert records[0].data == (0x0ABC,) and records[1].data == (0x0F0F,)
    assert monitor.terminals[5].selected_shutdown == {3}


def test_no_response_is_retried_on_the_other_bus(run_bus: Runner) -> None:
    records, monitor = run_bus([rt_bc(5, 3, 3)],
                               injections=[Injection("no_response", rt=5)])
    assert [(r.bus, r.errors) for r in records] == [("A", ("no_response",)), ("B", ())]
    assert records[0].data == () and records[1].data == (0x300, 0x301, 0x302)
    assert [s.retry for s in monitor.sent] == [0, 1]


def test_retry_can_be_turned_off_and_absent_terminals_never_answer(run_bus: Runner) -> None:
    records, _ = run_bus([rt_bc(9, 3, 3)], retries=0)
    assert [(r.bus, r.errors) for r in records] == [("A", ("no_response",))]
    records, _ = run_bus([rt_bc(9, 3, 3)], retries=2)
    assert [r.bus for r in records] == ["A", "B", "A"]


@pytest.mark.parametrize("tx_silent", [True, False])
def test_rt_rt_silent_transmitter_leaves_the_receiver_silent(run_bus: Runner,
                                                            tx_silent: bool) -> None:
    responder = 0 if tx_silent else 1
    records, _ = run_bus([rt_rt(6, 2, 5, 3, 3)], retries=0,
                         injections=[Injection("no_response", responder=responder)])
    rec = records[0]
    assert "no_response" in rec.errors
    assert len(rec.status) == (0 if tx_silent else 1)
