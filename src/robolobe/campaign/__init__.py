"""Measured data: hammer-test campaigns, their test header and files.

The bottom layer for anything measured: :class:`Campaign` (postures, FRFs
per posture, the typed :class:`TestHeader`, optional hammer force levels),
its folder format (docs/guide/campaign.md: CSV or UFF 58) and UFF 58 files
(:mod:`robolobe.campaign.uff`). Simulation of campaigns lives in
:mod:`robolobe.twin.campaign` and returns this type; identification
(:mod:`robolobe.modal`) and diagnosis take it.
"""

from robolobe.campaign._io import (
    BUILTIN_ROBOTS,
    read_campaign,
    read_postures,
    write_campaign,
    write_postures,
)
from robolobe.campaign._model import (
    ALL_DIRS,
    FRF_COLUMNS,
    POSTURE_COLUMNS,
    TEST_KEYS,
    WINDOW_END_MIN,
    Campaign,
    PostureFRF,
    TestHeader,
)

__all__ = [
    "ALL_DIRS",
    "BUILTIN_ROBOTS",
    "FRF_COLUMNS",
    "POSTURE_COLUMNS",
    "TEST_KEYS",
    "WINDOW_END_MIN",
    "Campaign",
    "PostureFRF",
    "TestHeader",
    "read_campaign",
    "read_postures",
    "write_campaign",
    "write_postures",
]
