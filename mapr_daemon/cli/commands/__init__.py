"""``mapr``'s subcommands, one module each (named in :data:`mapr_daemon.cli.main.SUBCOMMANDS`).

Each module exposes ``add_subparser(subparsers)`` and sets ``func(args) -> int``. Nothing is
imported here: :func:`mapr_daemon.cli.main.build_parser` imports only the subcommand named on
the command line.
"""
