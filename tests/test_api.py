"""The public API: ``import robolobe as rl`` is cheap and every listed name resolves."""

from __future__ import annotations

import subprocess
import sys

import pytest

import robolobe as rl
from robolobe.tl.dataset import TrustWarning


def test_import_is_lazy() -> None:
    code = (
        "import sys, robolobe as rl; "
        "heavy = [m for m in ('robolobe.plan', 'robolobe.tl', 'torch', 'matplotlib', 'casadi') "
        "if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("name", sorted(set(rl.__all__) - {"__version__"}))
def test_every_public_name_resolves(name: str) -> None:
    obj = getattr(rl, name)
    assert obj is not None
    assert callable(obj)
    assert (obj.__doc__ or "").strip(), f"rl.{name} has no docstring"


def test_public_names_survive_subpackage_imports() -> None:
    # importing a subpackage sets an attribute of that name on robolobe: no
    # public name may be a subpackage's name, or it would turn into a module
    import pkgutil

    subpackages = {m.name for m in pkgutil.iter_modules(rl.__path__)}
    assert not (set(rl.__all__) & subpackages)


def test_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'plan_pth'"):
        _ = rl.plan_pth  # type: ignore[attr-defined]


@pytest.mark.slow
def test_user_story_campaign_folder_to_written_plan(tmp_path) -> None:
    """The README's Python story: a campaign folder to a written plan."""
    import json
    from importlib import resources

    import numpy as np

    from robolobe.campaign import write_campaign
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.designs import design_arrays, load_seed_design

    # the lab's part: hammer tests of robot B at the seed paper's 20 postures
    ids, q, roles = design_arrays(load_seed_design("B"))
    train = [i for i, r in zip(ids, roles, strict=True) if r != "test"]
    sel = np.array([i in train for i in ids])
    twin = rl.Twin(rl.load_robot("B"))
    camp = simulate_campaign(
        twin.receptance, "B", train, q[sel], rng=np.random.default_rng(1), dirs=("xx", "yy", "zz")
    )
    write_campaign(tmp_path / "camp", camp, fmt="csv")
    examples = resources.files("robolobe.data").joinpath("examples")

    # the story
    campaign = rl.read_campaign(tmp_path / "camp")
    modal = rl.identify(campaign)
    with pytest.warns(TrustWarning, match="missing mode value"):  # modes a test did not see
        model = rl.transfer(modal.table, robot="B")  # the default predictor
    job = rl.load_job(examples.joinpath("job_B_contour.toml"))
    plan = rl.plan_path(examples.joinpath("contour.apt"), job, modes=model)
    rl.write_plan(plan, tmp_path / "out")

    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["mode_source"].startswith("corrected twin of")
    assert summary["robust"] is True  # on the predictor's own calibrated spread
    assert summary["min_margin"] >= job.plan.safety_factor - 1e-6
    assert (tmp_path / "out" / "report.html").exists()
