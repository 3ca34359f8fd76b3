"""``mapr demo``: the main job, as far as it is built.

Today: a short stretch of 1553 traffic (a BC-to-RT position command, an RT-to-BC feedback
transfer, a transmit-status mode code) is encoded to a bit-level capture with the standard's
worst-case receiver impairments, two faults are injected (a parity error and a bit without
its mid-bit transition), and the capture is decoded back and shown word by word, the way a
bus analyzer lists it. Later stages add the message assembler, the loopback bus with the
JSBSim flight and the reasoner.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from drivers.mil1553.decoder import ManchesterDecoder
from drivers.mil1553.encoder import NO_FAULT, Impairments, WordFault, encode_words
from drivers.mil1553.wordbatch import (
    BUS_NAMES,
    SYNC_CMD,
    SYNC_DATA,
    error_names,
    make_words,
)
from drivers.mil1553.words import CommandWord, StatusWord, format_data
from mapr_daemon.cli import exitcodes

SAMPLE_RATE = 10e6


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("demo", help="run the demonstration of the main job",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int, default=1)
    parser.set_defaults(func=run)


def demo_traffic() -> tuple[list[tuple[int, int, int, int]], list[WordFault], list[str]]:
    """Words of three messages with their roles, and the faults to inject."""
    rows: list[tuple[int, int, int, int]] = []
    roles: list[str] = []
    t = 2_000

    def word(sync: int, value: int, role: str, gap_ns: int = 0) -> None:
        nonlocal t
        t += gap_ns
        rows.append((t, 0, sync, value))
        roles.append(role)
        t += 20_050  # a word lasts 20 µs, 20.02 µs with the 0.1 % slow clock

    rx = CommandWord(rt=5, transmit=False, subaddress=1, count=2)
    word(SYNC_CMD, rx.value, "command")
    word(SYNC_DATA, 0x0F3C, "data")
    word(SYNC_DATA, 0x8000, "data")
    word(SYNC_CMD, StatusWord(rt=5).value, "status", gap_ns=6_000)
    tx = CommandWord(rt=5, transmit=True, subaddress=2, count=1)
    word(SYNC_CMD, tx.value, "command", gap_ns=10_000)
    word(SYNC_CMD, StatusWord(rt=5, service_request=True).value, "status", gap_ns=6_000)
    word(SYNC_DATA, 0x5555, "data")
    mode = CommandWord(rt=5, transmit=True, subaddress=31, count=2)
    word(SYNC_CMD, mode.value, "command", gap_ns=10_000)
    word(SYNC_CMD, StatusWord(rt=5, busy=True).value, "status", gap_ns=6_000)
    faults = [NO_FAULT] * len(rows)
    faults[2] = WordFault(parity=True)
    faults[6] = WordFault(no_transition=4)
    return rows, faults, roles


def describe(sync: int, value: int, role: str) -> str:
    if role == "command":
        return str(CommandWord.from_value(value))
    if role == "status":
        return str(StatusWord.from_value(value))
    return format_data(value)


def run(args: argparse.Namespace) -> int:
    rows, faults, roles = demo_traffic()
    impairments = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=args.seed)
    samples = encode_words(make_words(rows), SAMPLE_RATE, impairments=impairments, faults=faults)
    words = ManchesterDecoder(SAMPLE_RATE).decode_all(samples)
    print(f"MAPR demo: {len(rows)} words on bus A, encoded at {SAMPLE_RATE / 1e6:g} MS/s with "
          "+/-150 ns crossing jitter, a 100 ns dead band and a 0.1 % slow clock;")
    print("injected: a parity error (word 3) and a bit without its mid-bit transition (word 7).")
    print()
    print(f"{'time (us)':>10}  bus  sync  value  {'meaning':<38} errors")
    starts = np.array([r[0] for r in rows])
    for row in words:
        k = int(np.argmin(np.abs(starts - int(row["t_ns"]))))
        errs = error_names(int(row["errors"]))
        print(f"{int(row['t_ns']) / 1000:10.3f}   {BUS_NAMES[int(row['bus'])]}   "
              f"{'cmd ' if row['sync'] else 'data'}  {int(row['value']):04X}  "
              f"{describe(int(row['sync']), int(row['value']), roles[k]):<38} "
              f"{','.join(errs) if errs else '-'}")
    caught = sum(1 for row in words if row["errors"])
    print()
    print(f"{len(words)} words decoded, {caught} flagged; every injected fault caught: "
          f"{caught == sum(f.any for f in faults)}")
    return exitcodes.OK
