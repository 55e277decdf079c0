"""Diagnosis: locate the mismatch between a model and recordings, name the missing
physics, add it as an effect element, refit, and prove the fit improves.

Entry point: :func:`suspenv.diagnosis.engine.diagnose`; report:
:func:`suspenv.diagnosis.report.write_report`; blind benchmark:
:mod:`suspenv.diagnosis.benchmark`. See ``docs/diagnosis.md``.
"""
