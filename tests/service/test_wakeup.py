"""The self-pipe and the doorbell in-process, with real signals sent to this process."""

from __future__ import annotations

import os
import selectors
import signal
import threading

from mapr_daemon.service.wakeup import Doorbell, SignalPipe


def test_signals_arrive_in_order_through_the_pipe_and_handlers_are_restored() -> None:
    before = signal.getsignal(signal.SIGHUP)
    pipe = SignalPipe()
    try:
        with selectors.DefaultSelector() as selector:
            selector.register(pipe, selectors.EVENT_READ)
            assert selector.select(0) == []
            os.kill(os.getpid(), signal.SIGHUP)
            os.kill(os.getpid(), signal.SIGTERM)   # handled: the test process lives on
            assert selector.select(5)
            assert pipe.received() == [signal.SIGHUP, signal.SIGTERM]
            assert pipe.received() == []
    finally:
        pipe.close()
    assert signal.getsignal(signal.SIGHUP) is before


def test_a_ring_from_another_thread_wakes_select_and_is_cleared() -> None:
    bell = Doorbell()
    try:
        with selectors.DefaultSelector() as selector:
            selector.register(bell, selectors.EVENT_READ)
            for _ in range(3):
                threading.Thread(target=bell.ring).start()
            assert selector.select(5)
            bell.clear()
            assert selector.select(0) == []
            for _ in range(100_000):   # more rings than the socket holds: never blocks
                bell.ring()
            bell.clear()
            assert selector.select(0) == []
    finally:
        bell.close()
