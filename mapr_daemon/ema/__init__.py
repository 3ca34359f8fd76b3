"""The EMA plant model and its fault injection.

* :mod:`~mapr_daemon.ema.params` — actuator parameters from ``configs/actuators/*.yaml``.
* :mod:`~mapr_daemon.ema.faults` — the paper's Table 1 faults plus friction, compound sets.
* :mod:`~mapr_daemon.ema.degradation` — aging trajectories over many flights, with end of life.
* :mod:`~mapr_daemon.ema.plant` — :class:`EmaBatch`, stepped in chunks of sensor samples.
* :mod:`~mapr_daemon.ema.step` — the 25 us plant step, compiled (SMPS, bridge, motor, loops).
* :mod:`~mapr_daemon.ema.run` — whole runs over a profile and the ``.npz`` data format.
"""
