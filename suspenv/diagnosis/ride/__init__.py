"""The ride family: minibus ride recordings against the 7-DOF ride model
(:mod:`~suspenv.diagnosis.ride.family`), and the spectral test of measured road profiles
against ISO 8608 (:mod:`~suspenv.diagnosis.ride.road`). See ``docs/diagnosis_ride.md``.
"""
