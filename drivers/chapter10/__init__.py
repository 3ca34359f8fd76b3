"""IRIG 106 Chapter 10 recordings: MIL-STD-1553 Format 1 and ARINC 429 packets in and out.

pychapter10 handles the packet layer (headers, checksums, message headers); the modules
here turn its messages into :class:`~drivers.mil1553.record.MonitorRecord` and back, and
map the Chapter 10 block status word to MAPR's error names (:mod:`drivers.chapter10.status`).
"""
