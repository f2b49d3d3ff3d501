"""A campaign whose directions see different numbers of modes (issue 27, item 1).

Robot C's lateral driving point (``yy``) sees few of its modes in a hammer test
(an in-form C campaign of the out-of-form study, with every out-of-form part
taken out, had four ``yy`` modes against six in ``xx`` and ``zz``). The twin
methods pair measured modes with the twin's by frequency: the default transfer
must take such a campaign; the network, whose outputs are fixed, must refuse it
with a message that names the direction and the mode it lacks.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.tl.dataset import ModalDataset
from robolobe.tl.design import design_postures
from robolobe.tl.residual import CorrectedTwin
from robolobe.tl.transfer import transfer
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin.designs import TESTED_RANGES_DEG
from robolobe.twin.model import Twin


@pytest.fixture(scope="module")
def campaign():
    """20 noisy tests of a stiffer C; ``yy`` keeps only its two lowest modes."""
    base = load_robot("C")
    truth = base.with_stiffness(1.15 * np.asarray(base.stiffness))
    q = design_postures(
        base, 20, rng=np.random.default_rng(11), ranges_deg=TESTED_RANGES_DEG["C"]
    ).q_rad
    ds = twin_modal_dataset(
        Twin(truth),
        [f"T{i:02d}" for i in range(20)],
        q,
        directions=("xx", "yy", "zz"),
        rng=np.random.default_rng(12),
    )
    y = np.array(ds.y)
    y[:, 1, 2:] = np.nan  # yy: modes 3-5 not seen at any posture
    return ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y).to_frame()


def test_default_transfer_takes_a_direction_with_fewer_modes(campaign):
    df = campaign
    assert df.loc[df["dir"] == "yy", "mode"].max() == 2
    assert df.loc[df["dir"] == "xx", "mode"].max() == 5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = transfer(df, robot="C")  # was: "direction 'yy', mode 3: no posture has a value"
    assert isinstance(model, CorrectedTwin)
    # the calibration learned the stiffer gears from the directions that see the modes
    stiff = np.asarray(model.robot_.stiffness) / np.asarray(load_robot("C").stiffness)
    assert np.all(np.abs(stiff[:3] - 1.15) < 0.1), stiff


def test_network_transfer_refuses_it_naming_direction_and_mode(campaign):
    df = campaign
    with pytest.raises(InputError, match=r"direction 'yy'.*mode 3 at no posture"):
        transfer(df, robot="C", source="A", method="network")
