"""The scene: a scenario file parsed into frozen dataclasses, and the single description of
which FMUs a scene instantiates and how they connect (:mod:`.wiring`), which the master and
the SSP export (:mod:`.ssp`) both read."""
