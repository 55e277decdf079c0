"""Diagnosis of minibus ride recordings and measured road profiles.

Entry points: :func:`diagnose_ride` (pulse / random-road acceleration recordings
against the 7-DOF ride model) and :func:`diagnose_road` (a measured profile against
ISO 8608). See ``docs/diagnosis_ride.md``.
"""

from suspenv.diagnosis.ride.engine import (
    RideDiagnosis,
    diagnose_ride,
    locate_ride,
    screen_candidates,
)
from suspenv.diagnosis.ride.mismatch import OUT_OF_LIBRARY_KINDS
from suspenv.diagnosis.ride.model import RIDE_CANDIDATES, MinibusRideAdapter, ride_effect
from suspenv.diagnosis.ride.recording import (
    RideCase,
    RideTruth,
    make_ride_case,
    pulse_inputs_recording,
    random_road_inputs_recording,
    write_ride_case,
)
from suspenv.diagnosis.ride.report import write_ride_report
from suspenv.diagnosis.ride.residual import ResidualCheck, residual_check
from suspenv.diagnosis.ride.road import (
    RoadDiagnosis,
    diagnose_road,
    fit_psd,
    load_profile_txt,
    synthetic_profile,
    write_road_report,
)

__all__ = [
    "OUT_OF_LIBRARY_KINDS",
    "ResidualCheck",
    "RideDiagnosis",
    "residual_check",
    "RIDE_CANDIDATES",
    "MinibusRideAdapter",
    "RideCase",
    "RideTruth",
    "RoadDiagnosis",
    "diagnose_ride",
    "diagnose_road",
    "fit_psd",
    "load_profile_txt",
    "locate_ride",
    "make_ride_case",
    "pulse_inputs_recording",
    "random_road_inputs_recording",
    "ride_effect",
    "screen_candidates",
    "synthetic_profile",
    "write_ride_case",
    "write_ride_report",
    "write_road_report",
]
