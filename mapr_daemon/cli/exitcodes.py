"""Exit codes of ``mapr``, distinct per cause so scripts and systemd can tell them apart."""

OK = 0
FAILURE = 1
"""An unexpected internal error (a bug): the traceback is logged."""
USAGE = 2
"""A bad argument (checked before any backend opens: a value out of range, a filter no message
can match, an unknown backend or backend option), or an input file that cannot be read or is
not what it is named (one line names it)."""
DATAERR = 65
"""Some of the input is not there or could not be diagnosed, the rest was done (sysexits
EX_DATAERR): records ``mapr diagnose`` could not diagnose (each has its own error event), a
``mapr decode --c10-channel`` the recording does not hold (the line lists those it does),
``mapr commission`` inputs holding no BIT to commission from (one line per file)."""
CONFIG = 78
"""A configuration or ICD error (sysexits EX_CONFIG); listed in RestartPreventExitStatus=."""
UNAVAILABLE = 69
"""A backend or device that cannot be opened, or that failed (sysexits EX_UNAVAILABLE): no
libusb, no card, no serial port. ``mapr run`` exits with it when the configured backend can
never open on this machine; it is in RestartPreventExitStatus= with CONFIG. ``mapr fleet``
exits with it when its Dask scheduler cannot be reached or is lost mid-run."""
NOINPUT = 66
"""The fault catalog is missing, unreadable, corrupt or written by a newer MAPR (sysexits
EX_NOINPUT); ``mapr catalog`` prints one line naming the file."""
INTERRUPTED = 130
"""Stopped by Ctrl-C (``mapr record`` by SIGTERM too); the daemon, ``mapr run``, exits OK on
both, its normal stop."""
