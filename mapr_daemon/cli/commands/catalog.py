"""``mapr catalog``: query the fault catalog the daemon writes (read-only, safe while it runs).

    mapr catalog list --since 7d --asset EMA1 --min-severity 0.3
    mapr catalog show 42
    mapr catalog export --format csv -o faults.csv --since 2026-05-01
    mapr catalog export --what bits --format csv -o bits.csv   (or episodes, inflight; jsonl)
    mapr catalog trend EMA1 --plot ema1.png            (--hours: x in flight hours)
    mapr catalog stats --since 2h
    mapr catalog episodes --open --asset EMA1
    mapr catalog ack 3 --by "J. Smith" --note "capacitor replaced, WO 4711"

The catalog is ``--catalog PATH``, else ``$MAPR_CATALOG``, else /var/lib/mapr/catalog.sqlite
(the service's state directory). Times: ``2026-05-09``, ``2026-05-09T14:30Z`` (UTC unless an
offset is given) or an age such as ``90m``, ``2h``, ``7d``. ``--min-severity`` is the share
of the fault's range, 0..1 (a shorted or open switch counts as 1). ``--json`` prints JSON for
scripts. A missing or unreadable catalog is one line naming the file, exit code 66.

``ack`` is the one action that writes: it records who acknowledged a fault episode, when
(UTC) and a note, in one short transaction that is safe while the daemon writes (WAL, busy
timeout). An unknown episode, or one already acknowledged, is one line and exit code 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Iterable
from contextlib import ExitStack
from typing import IO, Any

from mapr_daemon import utc, views
from mapr_daemon.catalog import (
    CatalogReader,
    EventFilter,
    acknowledge,
    default_path,
    display_name,
)
from mapr_daemon.catalog.model import BitRecord, Event
from mapr_daemon.cli import exitcodes
from mapr_daemon.errors import CatalogError, EpisodeError

DEFAULT_LIMIT = 50


def _time(text: str) -> int:
    try:
        return utc.parse_time(text, time.time_ns())
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a severity between 0 and 1")
    return value


def _common() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--catalog", metavar="PATH", default=argparse.SUPPRESS,
                        help="catalog file (default: $MAPR_CATALOG or "
                             "/var/lib/mapr/catalog.sqlite)")
    common.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                        help="JSON for scripts instead of a table")
    return common


def _time_range(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--since", type=_time, metavar="TIME", help="from (inclusive)")
    parser.add_argument("--until", type=_time, metavar="TIME", help="to (exclusive)")


def _filters(parser: argparse.ArgumentParser) -> None:
    _time_range(parser)
    parser.add_argument("--asset", help="only this asset (e.g. EMA1)")
    parser.add_argument("--fault", help="only this fault mode (e.g. esr, short)")
    parser.add_argument("--min-severity", type=_fraction, metavar="S",
                        help="only severity >= S (0..1 of the fault's range)")


def add_subparser(subparsers: Any) -> None:
    common = _common()
    parser = subparsers.add_parser("catalog", help="query the fault catalog",
                                   description=__doc__, parents=[common],
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = parser.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True

    p = actions.add_parser("list", parents=[common], help="anomaly events, newest first")
    _filters(p)
    p.add_argument("--limit", type=int, default=DEFAULT_LIMIT,
                   help=f"at most this many (default {DEFAULT_LIMIT}; 0: all)")
    p.set_defaults(func=run, action_func=run_list)

    p = actions.add_parser("show", parents=[common], help="one event in full")
    p.add_argument("id", type=int)
    p.set_defaults(func=run, action_func=run_show)

    p = actions.add_parser("export", parents=[common],
                           help="events, BIT history or episodes as CSV or JSON (lines)")
    _filters(p)
    p.add_argument("--what", choices=["events", "bits", "episodes", "inflight"],
                   default="events",
                   help="events (default), bits (every BIT with its health and wear, and its "
                        "flight's in-flight estimate), episodes or inflight (each actuator's "
                        "per-flight estimate); bits take --asset/--fault/--since/--until, "
                        "episodes --asset, inflight --asset/--since/--until")
    p.add_argument("--format", choices=["csv", "json", "jsonl"], default=None,
                   help="csv (the default; flat, events keep params/evidence as JSON text), "
                        "jsonl (one record a line) or json (events: one array; else as "
                        "jsonl); --json is --format json")
    p.add_argument("-o", "--output", metavar="FILE", help="write here (default stdout)")
    p.set_defaults(func=run, action_func=run_export)

    p = actions.add_parser("trend", parents=[common], help="SoH and RUL of one asset over time")
    p.add_argument("asset", metavar="ACTUATOR",
                   help="TAIL/ACTUATOR (e.g. N900/EMA1), or a name only one aircraft has")
    _time_range(p)
    p.add_argument("--tail", help="only this aircraft's actuator of that name")
    p.add_argument("--plot", metavar="PNG", help="also draw it into this PNG (matplotlib)")
    p.add_argument("--hours", action="store_true",
                   help="x in flight hours instead of flights (with --plot)")
    p.set_defaults(func=run, action_func=run_trend)

    p = actions.add_parser("stats", parents=[common], help="bus health per interval, and gaps")
    _time_range(p)
    p.add_argument("--bus", choices=["A", "B"])
    p.add_argument("--by-rt", action="store_true",
                   help="per RT / direction / subaddress and mode code over the range "
                        "(both buses), instead of per interval")
    p.add_argument("--rt", metavar="LIST", help="with --by-rt: only these terminals (1-4,7)")
    p.add_argument("--sa", metavar="LIST", help="with --by-rt: only their subaddresses")
    p.add_argument("--tr", metavar="T|R", help="with --by-rt: only the side where the "
                                                "terminal transmits (T) or receives (R)")
    p.add_argument("--limit", type=int, default=DEFAULT_LIMIT,
                   help=f"the last N intervals (default {DEFAULT_LIMIT}; 0: all)")
    p.set_defaults(func=run, action_func=run_stats)


    p = actions.add_parser("episodes", parents=[common],
                           help="fault episodes, most recently active first")
    p.add_argument("--open", action="store_true", help="only the open ones")
    p.add_argument("--asset", metavar="NAME", help="only this asset (e.g. EMA1)")
    # the old name, kept working (hidden): `list` and `export` always said --asset
    p.add_argument("--actuator", dest="asset", help=argparse.SUPPRESS)
    p.set_defaults(func=run, action_func=run_episodes)

    p = actions.add_parser("ack", parents=[common],
                           help="acknowledge a fault episode (who, when, note)")
    p.add_argument("episode", type=int, metavar="EPISODE", help="episode id (catalog episodes)")
    p.add_argument("--by", required=True, metavar="NAME", help="who acknowledges it")
    p.add_argument("--note", metavar="TEXT", help="what was done or decided")
    p.set_defaults(func=run_ack)


def run(args: argparse.Namespace) -> int:
    """Open the catalog read-only and run the action; catalog errors are one line, exit 66."""
    path = getattr(args, "catalog", None) or default_path()
    try:
        with CatalogReader(path) as reader:
            code: int = args.action_func(reader, args)
            return code
    except CatalogError as error:
        where = f"{error.path}: " if error.path is not None else ""
        print(f"mapr catalog {args.action}: {where}{error.detail}", file=sys.stderr)
        return exitcodes.NOINPUT


def _wants_json(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "json", False))


def _filter(args: argparse.Namespace) -> EventFilter:
    return EventFilter(since_ns=args.since, until_ns=args.until, asset=args.asset,
                       fault=args.fault, min_severity=args.min_severity)


def _print_json(value: Any) -> None:
    json.dump(value, sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")


def run_list(reader: CatalogReader, args: argparse.Namespace) -> int:
    limit = args.limit if args.limit > 0 else None
    events = reader.events(_filter(args), limit=limit)
    if _wants_json(args):
        _print_json([views.event_json(e) for e in events])
    elif not events:
        print(f"no events in {reader.path} match")
    else:
        print(views.events_table(events))
        if limit is not None and len(events) == limit:
            print(f"(newest {limit} shown; --limit 0 for all)")
    return exitcodes.OK


def run_show(reader: CatalogReader, args: argparse.Namespace) -> int:
    event = reader.event(args.id)
    if event is None:
        print(f"mapr catalog show: no event {args.id} in {reader.path}", file=sys.stderr)
        return exitcodes.USAGE
    session = reader.session(event.session_id) if event.session_id is not None else None
    if _wants_json(args):
        _print_json({**views.event_json(event),
                     "session": None if session is None else dataclasses.asdict(session)})
    else:
        print(views.event_detail(event, session))
    return exitcodes.OK


def run_export(reader: CatalogReader, args: argparse.Namespace) -> int:
    if _wants_json(args) and args.format not in (None, "json"):
        print(f"mapr catalog export: error: --json and --format {args.format} ask for two "
              "formats (see mapr catalog export --help)", file=sys.stderr)
        return exitcodes.USAGE
    args.format = args.format or ("json" if _wants_json(args) else "csv")
    events = reader.iter_events(_filter(args), newest_first=False)
    with ExitStack() as stack:
        out: IO[str] = sys.stdout
        if args.output:
            try:
                out = stack.enter_context(open(args.output, "w", encoding="utf-8", newline=""))
            except OSError as error:
                print(f"mapr catalog export: {args.output}: {error.strerror}", file=sys.stderr)
                return exitcodes.USAGE
        n = _export(reader, args, events, out)
    if args.output:
        print(f"{n} {args.what} written to {args.output}", file=sys.stderr)
    return exitcodes.OK


def _export(reader: CatalogReader, args: argparse.Namespace, events: Iterable[Event],
            out: IO[str]) -> int:
    if args.what == "bits":
        records = [r for r in reader.bits(args.asset)
                   if (args.since is None or r.t_ns >= args.since)
                   and (args.until is None or r.t_ns < args.until)
                   and (args.fault is None or r.fault == args.fault)]
        inflight = {(r.tail, r.asset, r.flight): r for r in reader.inflight()}
        return views.write_bits(records, args.format, out, inflight)
    if args.what == "inflight":
        rows = [r for r in reader.inflight(args.asset)
                if (args.since is None or r.t_ns >= args.since)
                and (args.until is None or r.t_ns < args.until)]
        return views.write_inflight(rows, args.format, out)
    if args.what == "episodes":
        return views.write_episodes(reader.episodes(asset=args.asset), args.format, out)
    if args.format == "jsonl":
        return views.write_events_jsonl(events, out)
    write = views.write_csv if args.format == "csv" else views.write_json
    return write(events, out)


def _history(reader: CatalogReader, args: argparse.Namespace) -> tuple[str, list[BitRecord]]:
    """The asset's BIT history in the time range, and its display name; ``TAIL/ASSET``
    names one aircraft's actuator when no asset carries that whole name."""
    asset, tail = args.asset, args.tail
    records = reader.bits(asset, tail)
    if not records and tail is None and "/" in asset:
        tail, asset = asset.split("/", 1)
        records = reader.bits(asset, tail)
    records = [r for r in records if (args.since is None or r.t_ns >= args.since)
               and (args.until is None or r.t_ns < args.until)]
    tails = {r.tail for r in records}
    name = display_name(tails.pop(), asset) if len(tails) == 1 else asset
    return name, records


def which_actuator(reader: CatalogReader, asset: str, tail: str | None) -> str | None:
    """Why ``asset`` (``TAIL/ACTUATOR`` or a bare name, with ``--tail``) does not name
    exactly one actuator of the catalog, or None when it does: a bare name on several tails
    would merge their histories into one trend, an unknown name would print nothing."""
    known = reader.actuators()
    if tail is None and "/" in asset and (asset.split("/", 1)[0], asset.split("/", 1)[1]) in \
            known:
        return None
    if tail is not None:
        if (tail, asset) in known:
            return None
    else:
        tails = sorted({t for t, a in known if a == asset})
        if len(tails) > 1:
            names = ", ".join(display_name(t, asset) for t in tails)
            return (f"{asset} is on {len(tails)} aircraft: {names}; name one as "
                    "TAIL/ACTUATOR")
        if tails or any(display_name(t, a) == asset for t, a in known):
            return None
    listed = ", ".join(display_name(t, a) for t, a in known) or "none"
    return f"no actuator {display_name(tail or '', asset)} in {reader.path} (actuators: {listed})"


def run_trend(reader: CatalogReader, args: argparse.Namespace) -> int:
    problem = which_actuator(reader, args.asset, args.tail)
    if problem:
        print(f"mapr catalog trend: error: {problem}", file=sys.stderr)
        return exitcodes.USAGE
    name, records = _history(reader, args)
    events = [] if records else reader.trend(args.asset, args.since, args.until)
    if records and _wants_json(args):
        _print_json([{"time_utc": utc.fmt_time(r.t_ns), **views.bit_json(r)}
                     for r in records])
    elif records:
        print(views.bits_table(records))
    elif _wants_json(args):
        _print_json([{"time_utc": utc.fmt_time(e.t_ns), "t_ns": e.t_ns, "id": e.id,
                      "fault": e.fault, "severity": e.severity, "soh": e.soh, "rul": e.rul,
                      "rul_low": e.rul_low, "rul_high": e.rul_high, "rul_unit": e.rul_unit}
                     for e in events])
    elif not events:
        known = ", ".join(reader.assets()) or "none"
        print(f"no SoH/RUL for {args.asset} in {reader.path} (assets: {known})")
    else:
        print(views.trend_table(events))
    if args.plot:
        try:
            from mapr_daemon.views.plot import draw
            draw(records, name, args.plot, hours=args.hours)
        except ImportError:
            print("mapr catalog trend: --plot needs matplotlib (pip install matplotlib)",
                  file=sys.stderr)
            return exitcodes.UNAVAILABLE
        print(f"plot written to {args.plot}", file=sys.stderr)
    return exitcodes.OK


def run_stats(reader: CatalogReader, args: argparse.Namespace) -> int:
    if args.tr is not None and args.tr.upper() not in ("T", "R"):
        print(f"mapr catalog stats: error: --tr {args.tr}: allowed T or R", file=sys.stderr)
        return exitcodes.USAGE
    if not args.by_rt and (args.rt or args.sa or args.tr):
        print("mapr catalog stats: error: --rt, --sa and --tr select rows of --by-rt",
              file=sys.stderr)
        return exitcodes.USAGE
    if args.by_rt:
        return _run_rt_stats(reader, args)
    rows = reader.stats(args.since, args.until, args.bus,
                        limit=args.limit if args.limit > 0 else None)
    gaps = reader.gaps(args.since, args.until)
    if _wants_json(args):
        _print_json({"intervals": [r.as_dict() for r in rows],
                     "gaps": [g.as_dict() for g in gaps]})
        return exitcodes.OK
    print(views.stats_table(rows) if rows else "no bus statistics in range")
    if gaps:
        print()
        print(views.gaps_table(gaps))
    return exitcodes.OK


def _one_actuator(reader: CatalogReader, name: str) -> tuple[str | None, str]:
    """(tail, asset) of the one actuator ``name`` (``TAIL/ACTUATOR`` or a bare name that
    one aircraft carries) names, once :func:`which_actuator` has found no problem."""
    known = reader.actuators()
    if "/" in name and tuple(name.split("/", 1)) in known:
        tail, asset = name.split("/", 1)
        return tail, asset
    tails = sorted({t for t, a in known if a == name})
    return (tails[0] if tails else None), name


def run_episodes(reader: CatalogReader, args: argparse.Namespace) -> int:
    tail = None
    if args.asset is not None:   # one actuator: a name on several aircraft is refused
        problem = which_actuator(reader, args.asset, None)
        if problem:
            print(f"mapr catalog episodes: error: {problem}", file=sys.stderr)
            return exitcodes.USAGE
        tail, asset = _one_actuator(reader, args.asset)
        args.asset = asset
    episodes = reader.episodes(open_only=args.open, asset=args.asset, tail=tail)
    if _wants_json(args):
        _print_json([views.episode_json(ep) for ep in episodes])
    elif not episodes:
        which = "open " if args.open else ""
        whose = f" for {display_name(tail or '', args.asset)}" if args.asset else ""
        print(f"no {which}fault episodes{whose} in {reader.path}")
    else:
        print(views.episodes_table(episodes))
    return exitcodes.OK


def run_ack(args: argparse.Namespace) -> int:
    """The CLI's one write: the acknowledgment, beside a running daemon if need be."""
    path = getattr(args, "catalog", None) or default_path()
    try:
        episode = acknowledge(path, args.episode, args.by, args.note, time.time_ns())
    except EpisodeError as error:
        print(f"mapr catalog ack: {error}", file=sys.stderr)
        return exitcodes.USAGE
    except CatalogError as error:
        where = f"{error.path}: " if error.path is not None else ""
        print(f"mapr catalog ack: {where}{error.detail}", file=sys.stderr)
        return exitcodes.NOINPUT
    if _wants_json(args):
        _print_json(views.episode_json(episode))
    else:
        print(f"episode {episode.id} ({episode.asset}, {episode.part}) acknowledged by "
              f"{episode.acked_by} at {utc.fmt_time(episode.acked_ns)}")
    return exitcodes.OK


def _run_rt_stats(reader: CatalogReader, args: argparse.Namespace) -> int:
    from drivers.mil1553.sides import side_matches
    from mapr_daemon.cli.traffic.decode_filter import FilterError, address_set

    try:
        rts, sas = address_set("--rt", args.rt), address_set("--sa", args.sa)
    except FilterError as error:
        print(f"mapr catalog stats: error: {error}", file=sys.stderr)
        return exitcodes.USAGE
    transmit = None if args.tr is None else args.tr.upper() == "T"
    # the rows are sides (RT, T/R, SA): the same selection as decode's and monitor's filters
    rows = [r for r in reader.rt_stats(args.since, args.until)
            if side_matches(r.rt << 11 | (r.tr == "T") << 10 | r.sa << 5, rts, sas, transmit)]
    if _wants_json(args):
        _print_json({"rt_sa": [r.as_dict() for r in rows]})
        return exitcodes.OK
    print(views.rt_stats_table(rows) if rows else "no per-RT/SA statistics in range")
    return exitcodes.OK
