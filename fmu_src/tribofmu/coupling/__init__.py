"""The coupling: how the friction pair's FMUs are stepped together, with nothing of FMI in it.

Algorithms (:mod:`.algorithms`, the contact state machine of one implicit step in
:mod:`.contact`, the step-size rule in :mod:`tribofmu.physics.stepsize`), the coupled system
they step (:mod:`.system`), the one time base and interpolation (:mod:`.interpolation`), the
run's own error estimate (:mod:`.estimate`), the step quadrature of the energy audit
(:mod:`.quadrature`), and the in-process parts and pair model that the TriboPair FMU runs
(:mod:`.inprocess`, :mod:`.pair`). Everything here imports only the standard library and
:mod:`tribofmu.physics`: the FMUs ship this package whole. The fmpy side (FMU instances, the
run loop) is :mod:`tribofmu.master`.
"""
