"""``mapr report``: write the actuators' health as one self-contained HTML file.

    mapr report -o health.html
    mapr report -o health.html --catalog /srv/fleet/catalog.sqlite

One file with everything inline (CSS, the trend plots as PNG): a fleet overview first (the
tails, then the actuators, most urgent first, each with what to plan), how to read it (SoH
against the replace-at thresholds, the RUL's 90 % interval in words, which RUL to believe),
then per actuator its SoH and RUL, trend plot, fault episodes and the last BIT's evidence,
then the bus statistics. No script, no network: it opens offline in any browser. The plots
need matplotlib; without it the report is written without them. See docs/health.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from mapr_daemon.cli import exitcodes

HELP = "write the actuators' health as one self-contained HTML file"


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("report", help=HELP, description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-o", "--output", required=True, metavar="HTML",
                        help="the file to write (e.g. health.html)")
    parser.add_argument("--catalog", metavar="PATH",
                        help="catalog file (default: $MAPR_CATALOG or "
                             "/var/lib/mapr/catalog.sqlite)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.catalog import CatalogReader, default_path
    from mapr_daemon.errors import CatalogError
    from mapr_daemon.views.html_report import build

    path = args.catalog or default_path()
    try:
        with CatalogReader(path) as reader:
            text = build(reader, time.time_ns())
    except CatalogError as error:
        where = f"{error.path}: " if error.path is not None else ""
        print(f"mapr report: {where}{error.detail}", file=sys.stderr)
        return exitcodes.NOINPUT
    with open(args.output, "w", encoding="utf-8") as out:
        out.write(text)
    print(f"report written to {args.output}", file=sys.stderr)
    return exitcodes.OK
