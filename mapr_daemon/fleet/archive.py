"""Finding a fleet archive's recordings and telling each one's tail and flight.

An archive is a folder tree or a list of files. Tail number and flight come from the path by
a regular expression with named groups ``tail`` and ``flight``; the default reads
``TAIL/flight-0007.ch10``, and more generally a file in a folder named after the tail whose
name ends in the flight number. A file found under a folder given is matched against its path
below that folder alone (``/`` separators), so a recording at an archive's root has no tail
and is reported: it is never named after the archive's own folder. A file given by name is
matched against its absolute path (the folder it is in names its tail).
With ``tail_tmats`` (a TMATS attribute code such as ``G\\TA``, the test item), a recorder that
writes the tail number into its setup record is believed first: the attribute's value, when
the file's TMATS holds it, is the tail. A pattern whose ``tail`` group is optional (the
daemon's recordings, ``session-NNNNNN-...ch10``, sit in one folder) reads the tail from the
TMATS alone when the path has none; a file with neither is reported.
A ``fleet.json`` manifest at an archive root (:mod:`mapr_daemon.testbed.fleet` writes one)
may declare each recording's flight hours; without it the hours are the recorded time.

A recording is identified by the SHA-256 of its bytes, so a renamed or copied file is not
processed twice. A file whose tail and flight cannot be told is reported, not fatal. Every
path a recording carries is absolute: the workers of a cluster do not share the client's
working directory.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

from drivers.chapter10.recording_packets import DATA_TYPE_TMATS
from drivers.chapter10.tmats import parse_tmats
from drivers.chapter10.walker import HEADER_BYTES, SECONDARY_HEADER_BYTES, PacketWalker
from drivers.errors import MaprError
from mapr_daemon.errors import ConfigError

DEFAULT_PATTERN = r"(?:^|/)(?P<tail>[^/]+)/[^/]*?(?P<flight>\d+)\.(?:ch10|c10)$"
"""``TAIL/<anything>NNNN.ch10``: the folder is the tail, the file name's last number the flight."""
SUFFIXES = (".ch10", ".c10")
MANIFEST = "fleet.json"


@dataclasses.dataclass(frozen=True)
class Recording:
    """One flight's recording, as a fleet run sees it."""

    path: str
    tail: str
    flight: int
    digest: str
    flight_hours: float | None = None
    """Declared (manifest) flight hours; None: the recorded time counts."""


@dataclasses.dataclass(frozen=True)
class Unusable:
    """A file of the archive that cannot be processed, and why."""

    path: str
    reason: str


def compile_pattern(pattern: str) -> re.Pattern[str]:
    """``pattern`` compiled, checked to name the ``tail`` and ``flight`` groups."""
    try:
        compiled = re.compile(pattern)
    except re.error as error:
        raise ConfigError(f"not a regular expression: {error}", field="--pattern") from None
    missing = {"tail", "flight"} - set(compiled.groupindex)
    if missing:
        raise ConfigError(f"the pattern needs the named groups (?P<tail>...) and "
                          f"(?P<flight>...); missing {', '.join(sorted(missing))}",
                          field="--pattern")
    return compiled


def digest_of(path: Path) -> str:
    with path.open("rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


def tmats_of(path: Path) -> dict[str, str]:
    """The attributes of the file's first TMATS setup record (empty if it has none)."""
    walker = PacketWalker(path, frozenset({DATA_TYPE_TMATS}))
    try:
        for item in walker:
            header = item.header
            if header.data_type != DATA_TYPE_TMATS:
                continue
            start = HEADER_BYTES + (SECONDARY_HEADER_BYTES if header.secondary_header else 0)
            body = item.raw[start + 4:start + header.data_length]
            return parse_tmats(body.decode("ascii", errors="replace"))
    finally:
        walker.close()
    return {}


def discover(sources: Sequence[str | Path], pattern: str = DEFAULT_PATTERN,
             tail_tmats: str | None = None) -> tuple[list[Recording], list[Unusable]]:
    """The recordings under ``sources`` (folders searched recursively for ``*.ch10`` and
    ``*.c10``, files taken as given), sorted by tail and flight, and the files that cannot
    be used. The same content found twice is kept once."""
    compiled = compile_pattern(pattern)
    found: list[Recording] = []
    bad: list[Unusable] = []
    seen: set[str] = set()
    for source in sources:
        root = Path(os.path.abspath(source))
        if root.is_dir():
            files: Iterable[Path] = sorted(p for p in root.rglob("*")
                                           if p.suffix.lower() in SUFFIXES and p.is_file())
            base = root
        else:
            files, base = [root], None
        hours = _declared_hours(root.parent if base is None else base)
        for file in files:
            recording = _recording(file, base, compiled, hours, bad, tail_tmats)
            if recording is not None and recording.digest not in seen:
                seen.add(recording.digest)
                found.append(recording)
    found.sort(key=lambda r: (r.tail, r.flight, r.path))
    return found, bad


def _recording(file: Path, base: Path | None, pattern: re.Pattern[str],
               hours: dict[str, float], bad: list[Unusable],
               tail_tmats: str | None) -> Recording | None:
    """``file`` as a recording (``base``: the archive folder it was found under, None for a
    file given by name), or None with the reason added to ``bad``."""
    if base is None:
        named, relative = file.as_posix(), file.name
    else:
        named = relative = file.relative_to(base).as_posix()
    match = pattern.search(named)
    if match is None:
        where = "its path" if base is None else f"its path below the archive {base}"
        bad.append(Unusable(str(file), f"tail and flight not in {where} (see --pattern)"))
        return None
    try:
        digest = digest_of(file)
    except OSError as error:
        bad.append(Unusable(str(file), f"cannot read: {error.strerror or error}"))
        return None
    tail = match["tail"]
    if tail_tmats is not None:
        with contextlib.suppress(MaprError):   # not Chapter 10: the task will say so
            tail = tmats_of(file).get(tail_tmats) or tail
    if not tail:   # an optional tail group that did not take part, and no TMATS tail
        bad.append(Unusable(str(file), f"no tail in its path nor in its TMATS "
                                       f"{tail_tmats or '(see --tail-tmats)'}"))
        return None
    return Recording(str(file), tail, int(match["flight"]), digest, hours.get(relative))


def _declared_hours(base: Path) -> dict[str, float]:
    """Flight hours by path relative to ``base`` from ``base/fleet.json`` (empty when absent
    or unreadable: the recorded time counts then)."""
    try:
        manifest = json.loads((base / MANIFEST).read_text(encoding="utf-8"))
        return {str(r["path"]): float(r["flight_hours"]) for r in manifest["recordings"]
                if r.get("flight_hours") is not None}
    except (OSError, ValueError, KeyError, TypeError):
        return {}
