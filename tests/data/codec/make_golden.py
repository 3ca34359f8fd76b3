"""Regenerate the golden captures in this folder (run from the repository root).

    python tests/data/codec/make_golden.py

The captures are committed; the tests decode them and compare with the committed
``*.expected.jsonl``. Regenerate only on purpose: a change in the decoder's output on these
files is exactly what the golden tests exist to catch.
"""

from __future__ import annotations

import json
from pathlib import Path

from drivers.capturefile import write_raw, write_sigrok
from drivers.mil1553.decoder import decode_capture
from drivers.mil1553.encoder import Impairments, WordFault, encode_words
from drivers.mil1553.wordbatch import make_words, word_to_json

HERE = Path(__file__).parent
RATE = 10e6

# A BC->RT transfer, an RT->BC transfer on bus B, the standard's symmetry patterns, and four
# corrupted words: parity, a missing mid-bit transition, one bit short, one bit long.
ROWS = [
    (2_000, 0, 1, 0x2822), (22_020, 0, 0, 0x8000), (42_040, 0, 0, 0x7FFF),
    (68_000, 0, 1, 0x2800),
    (100_000, 1, 1, 0x2C41), (126_000, 1, 1, 0x2800), (146_020, 1, 0, 0x5555),
    (180_000, 0, 0, 0xAAAA), (210_000, 0, 0, 0x0000), (240_000, 0, 0, 0xFFFF),
    (280_000, 0, 0, 0x1234), (310_000, 0, 0, 0x1234), (340_000, 1, 0, 0x1234),
    (370_000, 1, 0, 0x1234),
]
FAULTS = [WordFault()] * 10 + [WordFault(parity=True), WordFault(no_transition=7),
                               WordFault(bit_count=-1), WordFault(bit_count=1)]


def main() -> None:
    imp = Impairments(jitter_ns=100, dead_band_ns=60, rate_error=5e-4, seed=2)
    samples = encode_words(make_words(ROWS), RATE, impairments=imp, faults=FAULTS)
    write_raw(HERE / "golden-10MSps.bin", samples)
    # The .sr file names its channels as a logic analyzer user would, in another order.
    order = [2, 3, 0, 1]  # D0 = B_RX, D1 = B_RXB, D2 = A_RX, D3 = A_RXB
    remapped = sum(((samples >> src) & 1) << dst for dst, src in enumerate(order))
    write_sigrok(HERE / "golden-10MSps.sr", remapped.astype("uint8"), RATE,
                 names=["bus_b_rx", "bus_b_rxb", "bus_a_rx", "bus_a_rxb"])
    with open(HERE / "golden.expected.jsonl", "w") as out:
        for row in decode_capture(samples, RATE):
            out.write(json.dumps(word_to_json(row)) + "\n")


if __name__ == "__main__":
    main()
