"""Capture files at the bit-level seam: raw sample bytes and sigrok session (``.sr``) files.

Raw: one byte per sample in the format of DESIGN.md (bit0 = bus A RX, bit1 = bus A RXB,
bit2 = bus B RX, bit3 = bus B RXB); the sample rate is not stored, so the user gives it.

sigrok session (format version 2, what PulseView and ``sigrok-cli -o x.sr`` write): a zip
holding ``version``, an INI ``metadata`` file (``samplerate``, ``probeN`` channel names,
``unitsize``) and the samples in ``logic-1-1``, ``logic-1-2``, ... . Channels are mapped to
our four receiver outputs by name (``A_RX``, ``A_RXB``, ``B_RX``, ``B_RXB``, any case) or by
an explicit list, so a capture from an ordinary logic analyzer can be decoded.
"""

from __future__ import annotations

import configparser
import io
import re
import sys
import zipfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from drivers.errors import CaptureFormatError

RECEIVER_CHANNELS = ("A_RX", "A_RXB", "B_RX", "B_RXB")
"""Our four inputs, in capture bit order."""
CHUNK_BYTES = 1 << 20


@dataclass(frozen=True, slots=True)
class CaptureSource:
    """An opened capture: its sample rate and a way to stream its samples in chunks."""

    name: str
    sample_rate: float
    chunks: Iterator[npt.NDArray[np.uint8]]


def parse_samplerate(text: str) -> float:
    """Parse ``"10 MHz"``, ``"24MHz"``, ``"500 kHz"`` or ``"10000000"`` to Hz."""
    match = re.fullmatch(r"\s*([0-9.]+(?:[eE][+-]?\d+)?)\s*([kMG]?)(?:Hz)?\s*", text)
    if not match:
        raise ValueError(f"not a sample rate: {text!r}")
    scale = {"": 1.0, "k": 1e3, "M": 1e6, "G": 1e9}[match.group(2)]
    return float(match.group(1)) * scale


def channel_map(names: Sequence[str], wanted: Sequence[str] | None = None) -> list[int | None]:
    """For each of our four receiver outputs, the index of the capture channel that holds it.

    ``names`` are the capture's channel names in bit order; ``wanted`` lists, in the order
    A_RX, A_RXB, B_RX, B_RXB, the capture channel names to use (an empty name = absent).
    Without ``wanted``, channels named like our inputs are used.
    """
    lookup = {n.strip().upper(): i for i, n in enumerate(names)}
    if wanted is None:
        found: list[int | None] = [lookup.get(c) for c in RECEIVER_CHANNELS]
        if found[0] is None and found[2] is None:
            raise CaptureFormatError(
                f"no channel named {'/'.join(RECEIVER_CHANNELS)} among {list(names)}; "
                "name them with --channels A_RX,A_RXB,B_RX,B_RXB")
        return found
    if len(wanted) != 4:
        raise CaptureFormatError("--channels needs four names: A_RX,A_RXB,B_RX,B_RXB")
    result: list[int | None] = []
    for name in wanted:
        if not name:
            result.append(None)
        elif name.strip().upper() in lookup:
            result.append(lookup[name.strip().upper()])
        else:
            raise CaptureFormatError(f"channel {name!r} is not in the capture {list(names)}")
    return result


def remap_table(mapping: Sequence[int | None], unitsize: int) -> npt.NDArray[np.uint8]:
    """A lookup table from a capture sample unit to our byte format."""
    size = 1 << (8 * unitsize)
    units = np.arange(size, dtype=np.int64)
    table = np.zeros(size, dtype=np.uint8)
    for bit, source in enumerate(mapping):
        if source is not None:
            table |= (((units >> source) & 1) << bit).astype(np.uint8)
    return table


def open_raw(path: str, sample_rate: float) -> CaptureSource:
    """Stream a raw capture (``-`` for standard input)."""
    if sample_rate <= 0:
        raise CaptureFormatError(f"{path}: a raw capture needs --samplerate")

    def chunks() -> Iterator[npt.NDArray[np.uint8]]:
        stream = sys.stdin.buffer if path == "-" else _open(path)
        try:
            while block := stream.read(CHUNK_BYTES):
                yield np.frombuffer(block, dtype=np.uint8)
        finally:
            if stream is not sys.stdin.buffer:
                stream.close()

    if path != "-":
        _open(path).close()  # fail now, with the file named, rather than mid-stream
    return CaptureSource(path, sample_rate, chunks())


def _open(path: str) -> io.BufferedReader:
    try:
        return open(path, "rb")  # closed by the generator that streams it
    except OSError as error:
        raise CaptureFormatError(f"{path}: {error.strerror or error}") from error


def open_sigrok(path: str, channels: Sequence[str] | None = None,
                sample_rate: float | None = None) -> CaptureSource:
    """Stream a sigrok session file, its channels mapped to our four receiver outputs."""
    try:
        archive = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as error:
        raise CaptureFormatError(f"{path}: not a readable sigrok session ({error})") from error
    try:
        meta = configparser.ConfigParser(interpolation=None)
        meta.read_string(archive.read("metadata").decode("utf-8", "replace"))
    except (KeyError, configparser.Error, zipfile.BadZipFile) as error:
        archive.close()
        raise CaptureFormatError(f"{path}: sigrok metadata missing or invalid ({error})") from error
    device = next((s for s in meta.sections() if s.startswith("device")), None)
    if device is None:
        archive.close()
        raise CaptureFormatError(f"{path}: sigrok metadata has no [device] section")
    dev = meta[device]
    try:
        rate = sample_rate or parse_samplerate(dev.get("samplerate", ""))
        probes = int(dev.get("total probes", "0"))
        unitsize = int(dev.get("unitsize", "1"))
    except ValueError as error:
        archive.close()
        raise CaptureFormatError(f"{path}: sigrok metadata: {error}") from error
    if unitsize not in (1, 2):
        archive.close()
        raise CaptureFormatError(f"{path}: unitsize {unitsize} is not supported (1 or 2)")
    names = [dev.get(f"probe{i}", f"D{i - 1}") for i in range(1, probes + 1)]
    table = remap_table(channel_map(names, channels), unitsize)
    prefix = dev.get("capturefile", "logic-1")
    parts = sorted((n for n in archive.namelist() if re.fullmatch(re.escape(prefix) + r"-\d+", n)),
                   key=lambda n: int(n.rsplit("-", 1)[1]))
    if not parts and prefix in archive.namelist():
        parts = [prefix]
    dtype = np.uint8 if unitsize == 1 else np.dtype("<u2")

    def chunks() -> Iterator[npt.NDArray[np.uint8]]:
        try:
            for part in parts:
                raw = archive.read(part)
                usable = len(raw) - len(raw) % unitsize
                yield table[np.frombuffer(raw[:usable], dtype=dtype)]
        finally:
            archive.close()

    return CaptureSource(path, rate, chunks())


def open_capture(path: str, sample_rate: float | None = None,
                 channels: Sequence[str] | None = None) -> CaptureSource:
    """Open a raw or sigrok capture; sigrok is recognised by its zip signature."""
    if path != "-":
        try:
            with open(path, "rb") as probe:
                is_zip = probe.read(4) == b"PK\x03\x04"
        except OSError as error:
            raise CaptureFormatError(f"{path}: {error.strerror or error}") from error
        if is_zip:
            return open_sigrok(path, channels, sample_rate)
    if channels is not None:
        raise CaptureFormatError(f"{path}: --channels applies to sigrok .sr files only")
    return open_raw(path, sample_rate or 0.0)


def write_raw(path: str | Path, samples: npt.NDArray[np.uint8]) -> None:
    """Write samples as a raw capture."""
    Path(path).write_bytes(np.ascontiguousarray(samples, dtype=np.uint8).tobytes())


def write_sigrok(path: str | Path, samples: npt.NDArray[np.uint8], sample_rate: float,
                 names: Sequence[str] = RECEIVER_CHANNELS, chunk: int = 4 << 20) -> None:
    """Write samples as a sigrok session file (format version 2) with named channels."""
    rate = f"{sample_rate / 1e6:g} MHz" if sample_rate >= 1e6 else f"{sample_rate:g} Hz"
    lines = ["[global]", "sigrok version=0.5.2", "", "[device 1]", "capturefile=logic-1",
             f"total probes={len(names)}", f"samplerate={rate}", "total analog=0"]
    lines += [f"probe{i + 1}={name}" for i, name in enumerate(names)]
    lines += ["unitsize=1", ""]
    data = np.ascontiguousarray(samples, dtype=np.uint8)

    def member(name: str) -> zipfile.ZipInfo:
        # A fixed date makes the same capture give the same file, byte for byte.
        info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
        info.compress_type = zipfile.ZIP_DEFLATED
        return info

    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr(member("version"), "2")
        archive.writestr(member("metadata"), "\n".join(lines))
        for index, start in enumerate(range(0, max(data.size, 1), chunk)):
            archive.writestr(member(f"logic-1-{index + 1}"), data[start:start + chunk].tobytes())
