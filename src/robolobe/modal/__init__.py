"""robolobe.modal: modal identification from hammer-test campaigns (docs/guide/physics.md).

From a campaign (docs/guide/campaign.md) to a modal dataset (section 3), what a
modal test engineer does with PolyMAX, done automatically and checked:

- :mod:`~robolobe.modal.quality`: FRF checks per posture and direction;
- :mod:`~robolobe.modal.plscf`: poly-reference least-squares complex frequency poles;
- :mod:`~robolobe.modal.stabilization`, :mod:`~robolobe.modal.selection`:
  stabilization diagram and automatic selection by clustering;
- :mod:`~robolobe.modal.refine`, :mod:`~robolobe.modal.lsfd`: pole refinement,
  residues with residual terms, modal stiffness;
- :mod:`~robolobe.modal.posture`: one posture end to end (window and
  truncation corrections);
- :mod:`~robolobe.modal.tracking`, :mod:`~robolobe.modal.identify`: tracking
  across postures, neighbour recovery, the modal table;
- :mod:`~robolobe.modal.synthesis`: FRF synthesis (FRAC, NRMSE and MAC
  live with the measured data, :mod:`robolobe.campaign.metrics`);
- :mod:`~robolobe.modal.modal_csv`: reading and writing ``modal.csv``;
- :mod:`~robolobe.modal.validation`: accuracy against known modes;
- :mod:`~robolobe.modal.plots`: stabilization diagrams and FRF overlays.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from robolobe.modal.identify import CampaignModal, identify_campaign, identify_frfs
    from robolobe.modal.modal_csv import MODAL_COLUMNS, read_modal_csv, write_modal_csv
    from robolobe.modal.posture import IdentifySettings, PostureModal, identify_posture
    from robolobe.modal.synthesis import synthesize_frf

# names imported on first use: a worker process of the identification imports only
# the per-posture modules, not pandas and the campaign code
_WHERE = {
    "CampaignModal": "identify",
    "identify_campaign": "identify",
    "identify_frfs": "identify",
    "MODAL_COLUMNS": "modal_csv",
    "read_modal_csv": "modal_csv",
    "write_modal_csv": "modal_csv",
    "IdentifySettings": "posture",
    "PostureModal": "posture",
    "identify_posture": "posture",
    "synthesize_frf": "synthesis",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        value = getattr(importlib.import_module(f"robolobe.modal.{_WHERE[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'robolobe.modal' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_WHERE])


__all__ = [
    "MODAL_COLUMNS",
    "CampaignModal",
    "IdentifySettings",
    "PostureModal",
    "identify_campaign",
    "identify_frfs",
    "identify_posture",
    "read_modal_csv",
    "synthesize_frf",
    "write_modal_csv",
]
