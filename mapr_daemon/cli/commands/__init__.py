"""``mapr``'s subcommands, one module each (named in :data:`mapr_daemon.cli.main.SUBCOMMANDS`)."""
