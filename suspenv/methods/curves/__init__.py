"""Curve identification (``suspenv identify``, method ``curves``): the axle fitted to whole
measured K&C curves.

The job (:mod:`.identify`), the noise-weighted curve fit (:mod:`.curve_fit`, on the shared
least-squares driver :mod:`suspenv.rigs.knc_fit`), what the curves identify
(:mod:`.identifiability`), the loop that adds the physics the residual names
(:mod:`.model_loop`) and the identified car's K&C sheet with its intervals
(:mod:`.knc_sheet`).
"""
