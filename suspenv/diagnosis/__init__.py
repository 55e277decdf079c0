"""Diagnosis: locate the mismatch between a model and recordings, name the missing
physics, add it as an effect element, refit, and prove the fit improves.

One loop (:func:`suspenv.diagnosis.engine.diagnose`) with pluggable families: a
component on a dyno or rig (:mod:`~suspenv.diagnosis.component`), the McPherson axle on a
K&C rig (:mod:`~suspenv.diagnosis.knc`), the minibus on ride tests
(:mod:`~suspenv.diagnosis.ride`), a measured road profile against ISO 8608's spectrum
(:mod:`~suspenv.diagnosis.road`). See ``docs/diagnosis.md``.
"""

from suspenv.diagnosis.engine import Diagnosis, diagnose

__all__ = ["Diagnosis", "diagnose"]
