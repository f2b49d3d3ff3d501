"""Compare robots for one job.

The bundled pocket job (Al7075-T6, 20 mm 3-flute end mill) planned on the
three built-in robots A (KUKA KR 300 R2700-2), B (Comau NJ 650-2.7) and C
(ABB IRB 4400/60), each from its own digital twin; the workpiece is placed
where each robot reaches it. Prints one row per robot and writes
``compare.csv``, ``compare.json``, ``compare.png`` and one plan folder per
robot. The same as ``robolobe compare pocket.nc --job job_A_pocket.toml
--robots A B C -o OUTDIR``.

Run: ``python examples/gallery/compare_robots_for_a_job.py OUTDIR``
"""

import sys
from importlib import resources
from pathlib import Path

from robolobe.plan import compare_robots, load_job
from robolobe.plan.compare import write_comparison

out = Path(sys.argv[1] if len(sys.argv) > 1 else "gallery-out")
examples = Path(str(resources.files("robolobe.data").joinpath("examples")))

job = load_job(examples / "job_A_pocket.toml")
comparison = compare_robots(examples / "pocket.nc", job, ["A", "B", "C"])

columns = ["robot", "status", "depth_mm", "rpm_min", "rpm_max", "mrr_cm3_per_min", "min_margin"]
print(comparison.table[columns].to_string(index=False))
print(f"written to {write_comparison(comparison, out / 'compare')}")
