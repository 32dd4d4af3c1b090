"""Studies built on the master: the monolithic reference solver, the accuracy study, parameter
sweeps, the regime metrics and the energy audit of a run."""
