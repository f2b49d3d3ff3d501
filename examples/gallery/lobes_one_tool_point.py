"""Stability lobes of one tool point.

A two-mode tool point (the same modes in feed and normal direction) cut in
Al7075-T6 with a 3-flute 20 mm end mill at half immersion, down milling.
The zero-order (Altintas-Budak) solver gives the stability limit over the
speed range; the script prints the critical depth and the best speed in the
range and writes ``lobes.csv`` and ``lobes.png``.

Run: ``python examples/gallery/lobes_one_tool_point.py OUTDIR``
"""

import sys
from pathlib import Path

import numpy as np

from robolobe.sld import (
    Cutter,
    CuttingConditions,
    ModalModel,
    get_material,
    save_lobe_plot,
    stability_lobes,
    write_lobes_csv,
)

out = Path(sys.argv[1] if len(sys.argv) > 1 else "gallery-out")
out.mkdir(parents=True, exist_ok=True)

# Tool-point modes: a holder mode and a tool mode [Hz, -, N/m].
dynamics = ModalModel.isotropic(f_hz=[650.0, 1800.0], zeta=[0.03, 0.02], k_N_per_m=[2.0e7, 1.2e7])
cutter = Cutter(diameter=0.020, teeth=3)
material = get_material("Al7075-T6")
conditions = CuttingConditions.from_immersion(0.5, "down")
rpm = np.linspace(5000.0, 24000.0, 400)

lobes = stability_lobes(dynamics, cutter=cutter, material=material, conditions=conditions, rpm=rpm)

a_min, rpm_at_min = lobes.minimum()
best = int(np.argmax(lobes.a_lim))
print(
    f"smallest stable depth in the range: {1e3 * float(a_min):.2f} mm "
    f"at {float(rpm_at_min):.0f} rpm"
)
print(
    f"best speed in the range: {rpm[best]:.0f} rpm, stable up to {1e3 * lobes.a_lim[best]:.2f} mm"
)

write_lobes_csv(out / "lobes.csv", lobes)
save_lobe_plot(lobes, out / "lobes.png")
print(f"wrote {out / 'lobes.csv'} and {out / 'lobes.png'}")
