"""``mapr devices``: the attached cards the backends recognize, and how to open each.

::

    mapr devices                          # a block per card: device, IDs, state, options
    mapr devices --json                   # {"cards": [...], "notes": [...]}
    mapr devices --config /etc/mapr/mapr.yaml   # the usb IDs and firmware from the config

Lists open1553 serial cards (every USB serial port in pyserial's listing, with its
udev-stable path: the card has no USB ID of its own) and FX2 logic analyzers (running
fx2lafw with its firmware version, or bare, needing the firmware). For each: the
``mapr monitor`` arguments and the daemon's ``backend:`` config line that open it, and any
problem in the way (permissions: systemd/60-mapr.rules and the dialout group). Nothing
found is not an error: exit 0 with a hint. See docs/hardware.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from drivers.backends import fx2
from drivers.backends.attached import UDEV_HINT, AttachedCard
from drivers.errors import BackendUnavailable
from mapr_daemon.cli import exitcodes

NONE_FOUND = ("no cards found. Plug the card in; if it is plugged in, check `lsusb`, the "
              f"kernel log (`dmesg | tail`) and the udev rule: {UDEV_HINT}. See docs/hardware.md.")


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("devices", help="list attached interface cards",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="one JSON object on stdout")
    parser.add_argument("--config", metavar="FILE",
                        help="take the usb backend's ids, bare_ids and firmware from this "
                             "daemon config")
    parser.add_argument("--usb-ids", metavar="VID:PID,...",
                        help="IDs of FX2 analyzers running fx2lafw (default "
                             f"{fx2.format_ids(fx2.FX2LAFW_IDS)})")
    parser.add_argument("--bare-ids", metavar="VID:PID,...",
                        help=f"IDs of bare FX2 chips (default {fx2.format_ids(fx2.BARE_IDS)})")
    parser.add_argument("--firmware", metavar="FILE", help="the fx2lafw firmware to check for")
    parser.set_defaults(func=run)


def usb_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The usb backend's ``ids``, ``bare_ids`` and ``firmware``: the command line over the
    config file over the defaults. ConfigError/BackendError name a bad value."""
    settings: dict[str, Any] = {"ids": list(fx2.FX2LAFW_IDS), "bare_ids": list(fx2.BARE_IDS),
                                "firmware": None}
    if args.config:
        from mapr_daemon.service.config import load_config
        config = load_config(args.config)
        if config.backend.name == "usb":
            options = config.backend.options
            for key in ("ids", "bare_ids"):
                if key in options:
                    settings[key] = fx2.parse_ids(options[key])
            if options.get("firmware"):
                settings["firmware"] = str(options["firmware"])
    if args.usb_ids:
        settings["ids"] = fx2.parse_ids(args.usb_ids)
    if args.bare_ids:
        settings["bare_ids"] = fx2.parse_ids(args.bare_ids)
    if args.firmware:
        settings["firmware"] = args.firmware
    return settings


def find_cards(settings: dict[str, Any]) -> tuple[list[AttachedCard], list[str]]:
    """Every recognized card, and notes on what could not be looked at (and why)."""
    cards: list[AttachedCard] = []
    notes: list[str] = []
    try:
        from drivers.backends.serial_card import serial_cards
        cards += serial_cards()
    except ImportError as error:
        notes.append(f"serial cards not listed: {error} (pip install pyserial)")
    try:
        import usb.core

        from drivers.backends.usb_card import usb_cards
    except ImportError as error:
        notes.append(f"USB analyzers not listed: {error} (pip install pyusb)")
    else:
        try:
            cards += usb_cards(**settings)
        except BackendUnavailable as error:
            notes.append(f"USB analyzers not listed: {error}")
        except usb.core.USBError as error:
            notes.append(f"USB analyzers not listed: {error}")
    return cards, notes


def render(card: AttachedCard) -> str:
    """A card as a few lines a user reads at a glance."""
    first = f"{card.backend:<7} {card.device}  {card.usb_id}  {card.description}"
    if card.serial_number:
        first += f"  serial number {card.serial_number}"
    lines = [first, f"        state:     {card.state}"]
    if card.stable_path:
        lines.append(f"        stable:    {card.stable_path}")
    lines.append(f"        monitor:   mapr monitor {card.monitor_args()}")
    lines.append(f"        config:    {card.config_line()}")
    if card.problem:
        lines.append(f"        PROBLEM:   {card.problem}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    cards, notes = find_cards(usb_settings(args))
    if not cards:
        notes.append(NONE_FOUND)
    if args.json:
        json.dump({"cards": [card.as_json() for card in cards], "notes": notes}, sys.stdout,
                  indent=2)
        sys.stdout.write("\n")
        return exitcodes.OK
    for card in cards:
        print(render(card))
    for note in notes:
        print(f"mapr devices: {note}", file=sys.stderr)
    return exitcodes.OK
