"""The ride family: minibus ride recordings against the 7-DOF ride model
(:mod:`~suspenv.diagnosis.ride.family`). Measured road profiles get a spectral test of
their own beside the loop (:mod:`suspenv.diagnosis.road`). See ``docs/diagnosis_ride.md``.
"""
