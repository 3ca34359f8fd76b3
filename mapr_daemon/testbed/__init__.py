"""The testbed: profiles (built-in test, JSBSim flights) and, later, the simulated RTs."""
