"""A component diagnosis loads only the component family: no K&C, ride or benchmark code.

Run in a fresh interpreter (``sys.modules`` of the test process holds everything the
other tests imported).
"""

from __future__ import annotations

import json
import subprocess
import sys

from benchmarks.component_truth import make_case
from suspenv.measurements import save_recording

FORBIDDEN = (
    "suspenv.diagnosis.knc",
    "suspenv.diagnosis.ride",
    "suspenv.models.mcpherson",
    "suspenv.models.minibus",
    "suspenv.rigs.knc",
    "suspenv.rigs.ride",
    "benchmarks",
)


def test_damper_diagnosis_imports_no_knc_or_ride_module(tmp_path):
    case = make_case("damper", 7, 0)
    rec_path = tmp_path / "damper.npz"
    save_recording(case.recording, rec_path)
    out = tmp_path / "out"
    code = (
        "import json, sys\n"
        "from suspenv.cli.main import main\n"
        f"rc = main(['diagnose', {str(rec_path)!r}, '--model', 'damper', '--out', {str(out)!r}])\n"
        "print(json.dumps({'rc': rc, 'modules': sorted(m for m in sys.modules "
        "if m.startswith(('suspenv', 'benchmarks')))}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["rc"] == 0
    loaded = [m for m in result["modules"] if m.startswith(FORBIDDEN)]
    assert loaded == [], f"a damper diagnosis imported {loaded}"
    assert "suspenv.diagnosis.component.family" in result["modules"]
    assert (out / "report.md").is_file()
