"""The FMI version the FMU framework (:mod:`.base`) is built on: 2 (pythonfmu).

The FMI 3.0 build (``tribofmu build --fmi 3``) ships this file with ``FMI_VERSION = 3`` in
its private copy of the package, so the same adapters run on pythonfmu3 there.
"""
FMI_VERSION = 2
