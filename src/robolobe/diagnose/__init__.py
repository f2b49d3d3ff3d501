"""Mismatch diagnosis: locate where a robot's recordings and its model disagree,
name the physics the model left out, fit it, and show the fit improve.

Public API::

    from robolobe.diagnose import diagnose, DiagnoseSettings, write_report
    d = diagnose("path/to/campaign")     # Diagnosis
    d.verdict, d.summary, d.fit_before, d.fit_after

Modules (one concept each): :mod:`~robolobe.diagnose.observations` (records on
one grid), :mod:`~robolobe.diagnose.noise` (noise scale),
:mod:`~robolobe.diagnose.residuals` (the residual and FRAC/NRMSE),
:mod:`~robolobe.diagnose.locate` (mismatch map, per-mode tables),
:mod:`~robolobe.diagnose.candidate` and :mod:`~robolobe.diagnose.library`
(named candidates), :mod:`~robolobe.diagnose.twin_model` (the twin as the fits
see it), :mod:`~robolobe.diagnose.fitting` (fit, uncertainty,
identifiability), :mod:`~robolobe.diagnose.selection` (cross-validation,
ranking, ``none``), :mod:`~robolobe.diagnose.pipeline` (end to end),
:mod:`~robolobe.diagnose.calibration` (the file's own values as a candidate),
:mod:`~robolobe.diagnose.forward` (several candidates, the test against the
noise), :mod:`~robolobe.diagnose.schema` (JSON), :mod:`~robolobe.diagnose.report`
(HTML), :mod:`~robolobe.diagnose.updated_model` (robot + effects files). The
concealed-campaign study is in ``studies/`` (an independent reference model).
"""

from robolobe.diagnose.library import FAMILIES
from robolobe.diagnose.pipeline import DiagnoseSettings, Diagnosis, diagnose
from robolobe.diagnose.report import write_report
from robolobe.diagnose.schema import DiagnosisReport, to_report
from robolobe.diagnose.selection import SelectionSettings
from robolobe.diagnose.updated_model import (
    load_updated_model,
    read_effects,
    write_updated_model,
)

__all__ = [
    "FAMILIES",
    "DiagnoseSettings",
    "Diagnosis",
    "DiagnosisReport",
    "SelectionSettings",
    "diagnose",
    "load_updated_model",
    "read_effects",
    "to_report",
    "write_report",
    "write_updated_model",
]
