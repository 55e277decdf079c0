"""The ride family: minibus ride recordings against the 7-DOF ride model
(:mod:`~suspenv.diagnosis.ride.family`); measured road profiles are the road family's
(:mod:`suspenv.diagnosis.road`). See ``docs/diagnosis_ride.md``.
"""
