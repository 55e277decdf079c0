"""Diagnosis of K&C rig recordings of the McPherson axle (see ``docs/diagnosis_knc.md``)."""
