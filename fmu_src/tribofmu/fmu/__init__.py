"""The FMU adapters: the shared framework (base) and one pythonfmu script per FMU (slaves/)."""
