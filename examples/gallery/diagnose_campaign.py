"""Diagnose a mismatch between the twin and the recordings.

The hammer tests are simulated on robot C carrying an accelerometer
adapter that its robot file leaves out: a 6 kg mass at the tool point
(:class:`robolobe.twin.effects.AddedMass`). :func:`robolobe.diagnose.diagnose`
compares the recordings with the robot file's twin, fits the candidate
physics effects, and names the one the data support. The script prints the
verdict and writes the report folder (``index.html``, figures,
``diagnosis.json``).

Run: ``python examples/gallery/diagnose_campaign.py OUTDIR``
"""

import sys
from pathlib import Path

import numpy as np

from robolobe.campaign import write_campaign
from robolobe.diagnose import diagnose, write_report
from robolobe.robots import load_robot
from robolobe.twin import Twin
from robolobe.twin.campaign import simulate_campaign
from robolobe.twin.designs import design_arrays, random_design
from robolobe.twin.effects import AddedMass

out = Path(sys.argv[1] if len(sys.argv) > 1 else "gallery-out")
rng = np.random.default_rng(3)

robot = load_robot("C")
truth = Twin(robot, (AddedMass(mass_kg=6.0),))
ids, q, _ = design_arrays(random_design(robot, 8, rng))
campaign = simulate_campaign(truth.receptance, "C", ids, q, rng=rng)
write_campaign(out / "campaign", campaign)

diagnosis = diagnose(campaign, robot=robot)
print(f"verdict: {diagnosis.verdict}")
for step in diagnosis.forward.steps:
    names = [p.name for p in step.candidate.params]
    fitted = ", ".join(
        f"{n} = {v:.3g} +- {e:.2g}" for n, v, e in zip(names, step.params, step.std, strict=True)
    )
    print(f"  {step.candidate.name}: {fitted} ({step.candidate.description})")
print(f"report: {write_report(diagnosis, out / 'diagnosis')}")
