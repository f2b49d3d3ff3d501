"""From a hammer-test campaign to a plan.

"Your robot" here is robot B whose joint-2 gearbox is 25 % softer than its
robot file says (the truth the calibration does not see). The script

1. simulates a hammer-test campaign of 12 random postures on that robot and
   writes it as a campaign folder (``campaign.toml``, ``postures.csv``,
   ``frf.csv``);
2. identifies the modes of every posture (pLSCF, stabilization, LSFD) and
   writes ``modal.csv``;
3. calibrates robot B's twin to the identified modes
   (:class:`robolobe.tl.TwinCalibration`) and writes the calibrated robot
   file ``B_calibrated.toml``;
4. plans the bundled contour job (``job_B_contour.toml``) with the
   calibrated robot.

Run: ``python examples/gallery/campaign_to_plan.py OUTDIR``
"""

import dataclasses
import sys
from importlib import resources
from pathlib import Path

import numpy as np

from robolobe.campaign import write_campaign
from robolobe.modal import identify_campaign, write_modal_csv
from robolobe.plan import load_job, plan_path, write_outputs
from robolobe.robots import load_robot
from robolobe.tl import TwinCalibration
from robolobe.twin import Twin
from robolobe.twin.campaign import simulate_campaign
from robolobe.twin.designs import design_arrays, random_design

out = Path(sys.argv[1] if len(sys.argv) > 1 else "gallery-out")
examples = Path(str(resources.files("robolobe.data").joinpath("examples")))
rng = np.random.default_rng(1)

# The robot that is tested: B with a softer joint 2 (unknown to robolobe).
nominal = load_robot("B")
joints = list(nominal.joints)
joints[1] = dataclasses.replace(
    joints[1], stiffness_Nm_per_rad=0.75 * joints[1].stiffness_Nm_per_rad
)
truth = dataclasses.replace(nominal, joints=tuple(joints))

# 1. hammer tests at 12 postures
ids, q, _ = design_arrays(random_design(nominal, 12, rng))
campaign = simulate_campaign(Twin(truth).receptance, "B", ids, q, rng=rng)
write_campaign(out / "campaign", campaign)
print(f"campaign: {len(ids)} postures -> {out / 'campaign'}")

# 2. modal identification
modal = identify_campaign(campaign)
write_modal_csv(out / "modal.csv", modal.table)
print(f"identified {len(modal.table)} modes; median FRAC {modal.fit['frac'].median():.3f}")

# 3. calibrate the twin of B to the identified modes
calibration = TwinCalibration(robot=nominal, random_state=0).fit(modal.table)
calibration.save(out / "B_calibrated.toml")
fitted = calibration.summary()
print("fitted factors on the robot file's values (joint stiffness k1..k6 first):")
print(fitted[fitted["unit"] == "x"].head(6).to_string(index=False))

# 4. plan the bundled contour with the calibrated robot
job = load_job(examples / "job_B_contour.toml")
plan = plan_path(examples / "contour.apt", job, robot=load_robot(out / "B_calibrated.toml"))
write_outputs(plan, out / "contour_plan", plots=False, html_report=False)
nominal_plan = plan_path(examples / "contour.apt", job)
print(
    f"depth per pass: calibrated twin {plan.summary.depth_mm:.2f} mm, "
    f"robot file as written {nominal_plan.summary.depth_mm:.2f} mm"
)
