"""Stability lobes for milling (docs/guide/physics.md: the ``sld`` package).

Cutters, materials, cutting conditions, directional factors, the batched
zero-order solution (Altintas & Budak 1995), the semi-discretization reference
(Insperger & Stepan), lobe envelopes and plots. Formulas and check values:
docs/references.md: stability lobes.

Typical use::

    from robolobe import sld
    model = sld.ModalModel.isotropic([922.0], [0.011], [1.34e6])
    lobes = sld.stability_lobes(
        model,
        cutter=sld.Cutter(diameter=0.02, teeth=2),
        material=sld.get_material("Al7075-T6"),
        conditions=sld.CuttingConditions.from_immersion(0.5, "down"),
        rpm=np.linspace(5000, 30000, 1000),
    )
    lobes.a_lim          # (1000,) m
    lobes.query(17250.0) # m, exact
"""

from robolobe.sld.conditions import CuttingConditions, engagement_angles, radial_immersion
from robolobe.sld.converged import LOBE_TOL, converged_lobes
from robolobe.sld.cutter import Cutter
from robolobe.sld.directional import (
    directional_factors,
    directional_matrix,
    interval_directional_average,
)
from robolobe.sld.frf import ModalModel, frequency_grid
from robolobe.sld.io import read_modes_csv, write_lobes_csv
from robolobe.sld.lobes import LobeDiagram, lobe_envelope, lobe_speeds
from robolobe.sld.material import Material, get_material, material_table
from robolobe.sld.plot import plot_lobes, save_lobe_plot
from robolobe.sld.sdm import SdmSystem, sdm_lobes, sdm_spectral_radius, sdm_system
from robolobe.sld.stability import stability_lobes
from robolobe.sld.toolpoint import feed_frame, rotate_frf, tool_point_model
from robolobe.sld.zoa import (
    LOW_IMMERSION,
    CriticalDepth,
    critical_depth,
    low_immersion_message,
    zoa_depth,
    zoa_eigenvalues,
    zoa_lobes,
)

__all__ = [
    "LOBE_TOL",
    "LOW_IMMERSION",
    "CriticalDepth",
    "Cutter",
    "CuttingConditions",
    "LobeDiagram",
    "Material",
    "ModalModel",
    "SdmSystem",
    "converged_lobes",
    "critical_depth",
    "directional_factors",
    "directional_matrix",
    "engagement_angles",
    "feed_frame",
    "frequency_grid",
    "get_material",
    "interval_directional_average",
    "lobe_envelope",
    "lobe_speeds",
    "low_immersion_message",
    "material_table",
    "plot_lobes",
    "radial_immersion",
    "read_modes_csv",
    "rotate_frf",
    "save_lobe_plot",
    "sdm_lobes",
    "sdm_spectral_radius",
    "sdm_system",
    "stability_lobes",
    "tool_point_model",
    "write_lobes_csv",
    "zoa_depth",
    "zoa_eigenvalues",
    "zoa_lobes",
]
