"""Bus-monitor backends. Each is imported only when opened (see :mod:`drivers.monitor`)."""
