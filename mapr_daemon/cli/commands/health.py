"""``mapr health``: every actuator's state of health and remaining useful life, one line each.

    mapr health
    mapr health --json --catalog /srv/fleet/catalog.sqlite

Per actuator (tail/asset): SoH (1.0 as commissioned, 0.0 at the leading mode's failure
threshold), the leading mode, the RUL with its 90 % interval in flights and in flight hours
(or, when there is no figure, the reason in words), its open fault episodes with the part,
its last BIT (UTC) and flight, and when it entered service (its first BIT). It reads the
catalog (``--catalog PATH``, else ``$MAPR_CATALOG``, else /var/lib/mapr/catalog.sqlite),
read-only and safe while the daemon writes. See docs/health.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from mapr_daemon.cli import exitcodes

HELP = "state of health and remaining useful life of every actuator"


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("health", help=HELP, description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--catalog", metavar="PATH",
                        help="catalog file (default: $MAPR_CATALOG or "
                             "/var/lib/mapr/catalog.sqlite)")
    parser.add_argument("--json", action="store_true", help="JSON for scripts")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.catalog import CatalogReader, default_path
    from mapr_daemon.errors import CatalogError
    from mapr_daemon.views import health_json, health_table
    from mapr_daemon.views.figures import inflight_json, inflight_lines

    path = args.catalog or default_path()
    try:
        with CatalogReader(path) as reader:
            rows = reader.health()
            latest = {(r.tail, r.asset): r for r in reader.inflight()}   # oldest first
    except CatalogError as error:
        where = f"{error.path}: " if error.path is not None else ""
        print(f"mapr health: {where}{error.detail}", file=sys.stderr)
        return exitcodes.NOINPUT
    if args.json:
        out = []
        for r in rows:   # each actuator's last in-flight estimate beside its BIT figures
            flight = latest.get((r.tail, r.asset))
            out.append({**health_json(r),
                        "inflight": None if flight is None else inflight_json(flight)})
        json.dump(out, sys.stdout, indent=1, sort_keys=True)
        sys.stdout.write("\n")
    elif not rows:
        print(f"no BIT history in {path} yet (the daemon, replay or fleet writes it)")
    else:
        print(health_table(rows))
        for (tail, asset), flight in sorted(latest.items()):
            print(f"{tail + '/' if tail else ''}{asset} " + "\n".join(inflight_lines(flight)))
    return exitcodes.OK
