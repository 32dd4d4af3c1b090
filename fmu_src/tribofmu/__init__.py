"""tribofmu: dry, fluid and boundary friction as FMI 2.0 co-simulation FMUs."""
__version__ = "0.1.0"
