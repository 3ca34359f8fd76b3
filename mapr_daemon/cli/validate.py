"""Argument checks shared by the subcommands, run while the command line is parsed.

A bad value must stop ``mapr`` before any backend opens, with argparse's one-line error and
exit code 2, naming the flag and what it accepts: ``monitor --rt 40`` waiting silently on a
bus where no terminal 40 can ever speak looks exactly like a dead bus. ``type=`` functions
here raise :class:`argparse.ArgumentTypeError` (argparse adds the flag's name); checks that
need several flags at once (:func:`impossible_filter`) return the problem as text and the
subcommand registers them as ``parser.set_defaults(validate=...)``, which
:func:`mapr_daemon.cli.main.main` runs right after parsing.

Light on purpose (standard library only): it is imported to build the parsers.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

MODE_FORMATS = frozenset({"MODE", "MODE_TX_DATA", "MODE_RX_DATA", "BCAST_MODE",
                          "BCAST_MODE_RX_DATA"})
"""Transfer formats of mode-code messages (subaddress 0 or 31)."""
DATA_FORMATS = frozenset({"BC_RT", "RT_BC", "RT_RT", "BCAST_BC_RT", "BCAST_RT_RT"})
"""Transfer formats carrying data to or from a subaddress 1-30."""
RECEIVE_ONLY = frozenset({"BC_RT", "BCAST_BC_RT", "MODE_RX_DATA", "BCAST_MODE_RX_DATA"})
"""Formats whose (first) command word is a receive command (T/R bit 0)."""
TRANSMIT_ONLY = frozenset({"RT_BC", "MODE_TX_DATA"})
"""Formats whose command word is a transmit command (T/R bit 1)."""
BROADCAST_ONLY_RT31 = frozenset({"BCAST_BC_RT", "BCAST_MODE", "BCAST_MODE_RX_DATA"})
"""Broadcast formats whose only terminal address is 31 (BCAST_RT_RT also names the
transmitter, any address)."""


def bounded_int(low: int, high: int, what: str) -> Callable[[str], int]:
    """A ``type=`` for an integer in ``low..high`` (e.g. an RT address 0-31)."""

    def parse(text: str) -> int:
        try:
            value = int(text, 0)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what} must be an integer {low}-{high}, not {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{what} must be {low}-{high}, not {value}")
        return value

    parse.__name__ = what  # argparse names the type in some messages
    return parse


def positive_int(what: str) -> Callable[[str], int]:
    """A ``type=`` for an integer >= 1 (a message count)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what} must be a whole number >= 1, not {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{what} must be >= 1, not {value}")
        return value

    parse.__name__ = what
    return parse


def positive_seconds(text: str) -> float:
    """A ``type=`` for a finite duration > 0 s."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds must be a number, not {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"seconds must be finite and > 0, not {text}")
    return value


def non_negative_seconds(text: str) -> float:
    """A ``type=`` for a finite duration >= 0 s (0 = off)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds must be a number, not {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"seconds must be finite and >= 0, not {text}")
    return value


def impossible_filter(rts: frozenset[int] | None, sas: frozenset[int] | None,
                      tr: str | None, formats: frozenset[str] | None) -> str | None:
    """Why a message filter (``--rt/--sa/--tr/--format``, all to match; each a set of
    allowed values or None for any) can never match a MIL-STD-1553B message, or None when
    some message can match it.

    Only combinations the standard rules out are refused, when every format asked for is
    ruled out: a mode-code format outside subaddress 0/31, a data format on subaddress 0/31
    only, a receive-only format with ``--tr T`` (and the reverse), a broadcast-only format on
    terminals other than 31. ``mapr decode`` and ``mapr monitor`` both refuse such a filter
    with exit code 2 before reading anything.
    """
    if not formats:
        return None
    reasons = [_impossible_one(rts, sas, tr, fmt) for fmt in sorted(formats)]
    if not all(reasons):
        return None
    return "; ".join(r for r in reasons if r)


def _impossible_one(rts: frozenset[int] | None, sas: frozenset[int] | None, tr: str | None,
                    fmt: str) -> str | None:
    sa_text = "" if sas is None else ",".join(str(s) for s in sorted(sas))
    rt_text = "" if rts is None else ",".join(str(r) for r in sorted(rts))
    if fmt in MODE_FORMATS and sas is not None and not sas & {0, 31}:
        return (f"--format {fmt} is a mode-code message: its subaddress is 0 or 31, so "
                f"--sa {sa_text} can never match")
    if fmt in DATA_FORMATS and sas is not None and sas <= {0, 31}:
        return (f"--sa {sa_text} carries mode codes only: a {fmt} message is on subaddress "
                "1-30, so the filter can never match")
    if tr is not None and fmt in RECEIVE_ONLY and tr.upper() == "T":
        return f"--format {fmt} is a receive command (R), so --tr T can never match"
    if tr is not None and fmt in TRANSMIT_ONLY and tr.upper() == "R":
        return f"--format {fmt} is a transmit command (T), so --tr R can never match"
    if fmt in BROADCAST_ONLY_RT31 and rts is not None and 31 not in rts:
        return f"--format {fmt} is broadcast (RT 31), so --rt {rt_text} can never match"
    return None


def parse_option(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` (a backend option) with the value read as int, float, bool or string;
    anything without ``=`` is refused (exit 2), so ``-O out.yaml`` is never taken silently."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"option {text!r} is not KEY=VALUE")
    value: Any = raw
    if raw.lower() in ("true", "false"):
        value = raw.lower() == "true"
    else:
        for kind in (int, float):
            try:
                value = kind(raw)
                break
            except ValueError:
                pass
    return key.strip(), value


class _DeprecatedOptionFlag(argparse.Action):
    """``-o KEY=VALUE``, the old spelling of ``-O/--option`` on ``monitor`` and ``record``:
    still taken (with a note on stderr) so that scripts keep working, but only as
    ``KEY=VALUE``; ``-o`` means ``--output`` everywhere else."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None
                 ) -> None:
        text = str(values)
        if "=" not in text:
            parser.error(f"-o {text}: -o is no longer a backend option here and this command "
                         "has no --output; backend options are -O KEY=VALUE")
        try:
            option = parse_option(text)
        except argparse.ArgumentTypeError as error:
            parser.error(f"-o: {error}")
        print(f"{parser.prog}: note: -o KEY=VALUE is deprecated, write -O {text} "
              "(-o means --output)", file=sys.stderr)
        getattr(namespace, self.dest).append(option)


def add_backend_options(parser: argparse.ArgumentParser, *, old_dash_o: bool) -> None:
    """``-O/--option KEY=VALUE`` (repeatable) into ``args.option``; ``old_dash_o`` also takes
    the deprecated ``-o KEY=VALUE`` (hidden from help) where ``-o`` used to mean it."""
    parser.add_argument("-O", "--option", action="append", default=[], metavar="KEY=VALUE",
                        type=parse_option,
                        help="backend option, repeatable (numbers and true/false converted)")
    if old_dash_o:
        parser.add_argument("-o", dest="option", action=_DeprecatedOptionFlag,
                            metavar="KEY=VALUE", help=argparse.SUPPRESS)


def add_filter_arguments(parser: argparse.ArgumentParser) -> None:
    """The message filters of ``decode`` and ``monitor`` (one set of flags, one syntax:
    lists and ranges), parsed and checked by
    :func:`mapr_daemon.cli.traffic.decode_filter.filter_from_args`."""
    group = parser.add_argument_group(
        "filters (all given must match; lists and ranges: --rt 1-4,7)",
        "--rt, --tr and --sa select one terminal's side of a message: an RT-RT transfer "
        "matches --rt 2 --tr T when RT 2 transmits in it, --rt 5 --sa 2 when RT 5's own "
        "subaddress is 2")
    group.add_argument("--rt", metavar="LIST", help="remote terminal addresses, 0-31")
    group.add_argument("--sa", metavar="LIST", help="subaddresses of that terminal, 0-31")
    group.add_argument("--tr", metavar="T|R", help="that terminal transmits (T) or receives (R)")
    from drivers.mil1553.record import MESSAGE_ERROR_NAMES, TransferFormat

    formats = group.add_argument("--format", dest="fmt", metavar="LIST",
                                 help="transfer formats, e.g. BC_RT,RT_RT")
    formats.completions = [str(f) for f in TransferFormat]  # type: ignore[attr-defined]
    group.add_argument("--errors", action="store_true", help="only messages with errors")
    error = group.add_argument("--error", metavar="LIST",
                               help="only messages with one of these errors, e.g. no_response")
    error.completions = list(MESSAGE_ERROR_NAMES)  # type: ignore[attr-defined]
    group.add_argument("--from", dest="t_from", metavar="SECONDS",
                       help="only messages starting at or after this bus time")
    group.add_argument("--to", dest="t_to", metavar="SECONDS",
                       help="only messages starting before this bus time")

