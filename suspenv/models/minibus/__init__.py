"""The reference minibus: vehicle data, suspension elements and the full-vehicle ride model."""

from suspenv.models.minibus.vehicle import (
    BASELINE_DESIGN,
    DESIGN_NAMES,
    DESIGN_VARIABLES,
    LOAD_CASES,
    REFERENCE_MINIBUS,
    STUDY_PICK,
    DamperCurve,
    DesignSI,
    LoadCase,
    Minibus,
    VehicleParams,
    design_space,
    design_to_si,
    vehicle_parameters,
)

__all__ = [
    "BASELINE_DESIGN",
    "DESIGN_NAMES",
    "DESIGN_VARIABLES",
    "LOAD_CASES",
    "REFERENCE_MINIBUS",
    "STUDY_PICK",
    "DamperCurve",
    "DesignSI",
    "LoadCase",
    "Minibus",
    "VehicleParams",
    "design_space",
    "design_to_si",
    "vehicle_parameters",
]
