"""Plan a toolpath: the bundled pocket on robot A.

Loads the bundled job (``job_A_pocket.toml``: Al7075-T6, 20 mm 3-flute end
mill, robot A's digital twin) and its G-code pocket, plans one depth per pass
and a spindle-speed schedule along the path, prints the headline numbers and
writes the report (``waypoints.csv``, ``summary.json``, plots,
``report.html``). The same as ``robolobe plan -o OUTDIR``.

Run: ``python examples/gallery/plan_bundled_pocket.py OUTDIR``
"""

import json
import sys
from importlib import resources
from pathlib import Path

from robolobe.plan import load_job, plan_path, write_outputs

out = Path(sys.argv[1] if len(sys.argv) > 1 else "gallery-out")
examples = Path(str(resources.files("robolobe.data").joinpath("examples")))

job = load_job(examples / "job_A_pocket.toml")
result = plan_path(examples / "pocket.nc", job)
report = write_outputs(result, out / "pocket_plan")

s = result.summary  # a PlanSummary: typed figures; s.to_dict() is summary.json
print(f"robot: {s.robot} ({s.mode_source})")
print(f"waypoints: {s.n_waypoints} ({s.n_cut} cutting)")
print(f"depth per pass: {s.depth_mm:.2f} mm, speed {s.rpm_min:.0f}-{s.rpm_max:.0f} rpm")
print(f"material removal rate: {s.mrr_cm3_per_min:.1f} cm^3/min, cycle time {s.cycle_time_s:.1f} s")
print(f"minimum stability margin: {s.min_margin:.2f} (safety factor {s.safety_factor})")
constant = s.vs_best_constant_speed  # the plan against the best constant speed (or None)
print(json.dumps(constant.to_dict() if constant is not None else None))
print(f"report written to {report}")
