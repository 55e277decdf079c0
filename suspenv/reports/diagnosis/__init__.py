"""Reports of diagnoses: Markdown, JSON and PNG figures.

One module per family: :mod:`.component` (damper, MR damper, friction guide, quarter car
on a rig), :mod:`.knc` (the McPherson axle on a K&C rig), :mod:`.ride` (the minibus on
ride tests) and :mod:`.road` (a measured road profile against ISO 8608).
:func:`write_diagnosis_report` picks the writer of the first three by the diagnosis's
``family``; only that family's module is imported.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def write_diagnosis_report(diag: Any, out_dir: str | Path) -> list[Path]:
    """The report of a diagnosis into ``out_dir`` by its ``family`` (``"knc"``, ``"ride"``,
    anything else: a component); returns the paths written."""
    if diag.family == "knc":
        from suspenv.reports.diagnosis.knc import write_knc_report

        return write_knc_report(diag, out_dir)
    if diag.family == "ride":
        from suspenv.reports.diagnosis.ride import write_ride_diagnosis_report

        return write_ride_diagnosis_report(diag, out_dir)
    from suspenv.reports.diagnosis.component import write_component_report

    return write_component_report(diag, Path(out_dir))
