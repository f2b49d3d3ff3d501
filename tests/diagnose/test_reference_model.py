"""The study's reference model (studies/diagnose_reference.py) against the effect library.

The concealed-campaign study judges the diagnosis on recordings made by a
reference model that shares no code with :mod:`robolobe.twin.effects` (its
own assembly of the extra physics and its own FRF). Here the two are
compared where both hold the same physics: they must agree to round-off,
which checks the library and the reference against each other.
"""

from __future__ import annotations

import numpy as np
import pytest
from diagnose_reference import SEED_TABLES, P, reference_receptance, seed_table_campaign

from robolobe.robots import load_robot
from robolobe.twin import effects as E
from robolobe.twin.model import Twin

DEG = np.pi / 180
PAIRS = [
    (P("mass", mass_kg=5.0), E.AddedMass(mass_kg=5.0)),
    (
        P("tool", f_hz=63.0, zeta=0.03, mass_kg=15.0, direction="x", local=True),
        E.ToolMode(f_hz=63.0, zeta=0.03, mass_kg=15.0, direction="x", mass_in_file=True),
    ),
    (
        P("tool", f_hz=31.0, zeta=0.03, mass_kg=4.0, direction="y"),
        E.ToolMode(f_hz=31.0, zeta=0.03, mass_kg=4.0, direction="y"),
    ),
    (
        P("servo", joint=1, k_Nm_per_rad=3e5, zeta=0.1, rotor_kgm2=40.0),
        E.ServoMode(joint=1, stiffness_Nm_per_rad=3e5, zeta=0.1, rotor_inertia_kgm2=40.0),
    ),
    (P("gravity", beta=0.3), E.GravityStiffening(beta=0.3)),
    (P("sensor_rot", rz=3 * DEG, rx=1 * DEG), E.SensorMisalignment(rz_rad=3 * DEG, rx_rad=DEG)),
    (P("hammer_rot", ry=10 * DEG), E.HammerDirection(ry_rad=10 * DEG)),
    (P("gain", gain=(1.0, 1.12, 1.0)), E.SensorGain(gain=(1.0, 1.12, 1.0))),
    (P("delay", delay_s=0.002), E.SensorDelay(delay_s=0.002)),
    (P("tcp_offset", offset_m=(0.0, 0.0, 0.05)), E.TcpOffset(offset_m=(0.0, 0.0, 0.05))),
]


@pytest.mark.parametrize(("ref", "eff"), PAIRS, ids=[p[0].kind for p in PAIRS])
def test_reference_and_library_agree(ref: object, eff: E.Effect) -> None:
    rb = load_robot("B")
    q = np.radians([[10.0, -60.0, 40.0, 10.0, 30.0, 0.0], [40.0, -40.0, 20.0, -30.0, 60.0, 20.0]])
    f = np.linspace(0.5, 120.0, 400)
    h_ref = reference_receptance(rb, [ref], q, f)  # type: ignore[list-item]
    h_lib = Twin(rb, (eff,)).receptance(q, f)
    h_nom = Twin(rb).receptance(q, f)
    scale = np.abs(h_lib).max()
    assert np.abs(h_ref - h_lib).max() < 1e-9 * scale
    assert np.abs(h_lib - h_nom).max() > 1e-2 * scale  # the physics is really there


def test_seed_table_campaign_rebuilds_the_measured_modes() -> None:
    camp = seed_table_campaign("B", noise=0.0)
    f = camp.frfs[0].freq_hz
    h = camp.frfs[0].H[:, 1, 1]
    # the first mode's peak sits at the table's frequency, its static level at sum 1/k
    f1 = SEED_TABLES["B"]["modes"][0][0][0]
    band = (f > 5) & (f < 9)
    assert f[band][np.argmax(np.abs(h[band]))] == pytest.approx(f1, abs=0.25)
    k = np.array([m[2] for m in SEED_TABLES["B"]["modes"][0]]) * 1e5
    assert h[0].real == pytest.approx(np.sum(1.0 / k), rel=1e-9)
    assert np.all(np.isnan(camp.frfs[0].H[:, 0, 0]))  # only yy was measured
