"""Exit codes of ``mapr``, distinct per cause so scripts and systemd can tell them apart."""

OK = 0
FAILURE = 1
"""An unexpected internal error (a bug): the traceback is logged."""
USAGE = 2
"""A bad argument, or an input file that cannot be read (one line names it)."""
DATAERR = 65
"""Some input records could not be diagnosed (sysexits EX_DATAERR): each has its own error event
and every other record was diagnosed (``mapr diagnose``)."""
CONFIG = 78
"""A configuration or ICD error (sysexits EX_CONFIG); listed in RestartPreventExitStatus=."""
UNAVAILABLE = 69
"""A backend or device that cannot be opened (sysexits EX_UNAVAILABLE)."""
NOINPUT = 66
"""The fault catalog is missing, unreadable, corrupt or written by a newer MAPR (sysexits
EX_NOINPUT); ``mapr catalog`` prints one line naming the file."""
INTERRUPTED = 130
"""Stopped by Ctrl-C."""
