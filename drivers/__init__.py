"""MIL-STD-1553B hardware-interface driver: words, Manchester-II codec, message assembly, backends.

This package knows the bus and nothing else; it never imports :mod:`mapr_daemon`.
"""

__all__: list[str] = []
