"""Fleet analysis: an archive of Chapter 10 recordings through the reasoner on Dask, into one
catalog (``mapr fleet``, docs/fleet.md)."""
