"""The MAPR daemon (``mapr run``): config, systemd notification, bus reader, service loop.

:mod:`.config` loads ``configs/mapr.yaml``; :mod:`.service` runs monitor -> ICD -> reasoner
-> catalog; :mod:`.reader` owns the backend (retries, bounded queue); :mod:`.bitwatch` cuts
the built-in tests out of the bus traffic for the reasoner; :mod:`.notify` is sd_notify;
:mod:`.logs` writes stderr lines with systemd priority prefixes; :mod:`.source` opens the
backend or the simulated aircraft. See docs/service.md.
"""
