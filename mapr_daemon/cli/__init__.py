"""The ``mapr`` command line: one module per subcommand, each with ``add_subparser``."""
