"""robolobe.tl: posture -> modal parameters by transfer learning (docs/guide/physics.md).

The seed paper's method (a 6 -> 5 x 32 ReLU -> 15 network per TCP direction,
pretrained on robot A and transferred to B and C with the first three layers
frozen), as a vectorized deep ensemble with calibrated spread, plus posture
design and the seed's evaluation protocol (the baselines and the schedule
study are study code: ``studies/tl_baselines.py``, ``studies/tl_schedule.py``).

Modules: :mod:`~robolobe.tl.dataset` (modal datasets), :mod:`~robolobe.tl.preprocess`
(features, scaling, augmentation), :mod:`~robolobe.tl.network`,
:mod:`~robolobe.tl.training`, :mod:`~robolobe.tl.estimator` (``ModalPredictor``),
:mod:`~robolobe.tl.presets`, :mod:`~robolobe.tl.models` (shipped A/B/C),
:mod:`~robolobe.tl.design`, :mod:`~robolobe.tl.evaluate`,
:mod:`~robolobe.tl.twin_data`, :mod:`~robolobe.tl.predict_io`,
:mod:`~robolobe.tl.graybox` (``TwinCalibration``: the physics-informed transfer),
:mod:`~robolobe.tl.residual` (``CorrectedTwin``: the calibrated twin plus a
learned correction, the default predictor of ``robolobe transfer``). The
concealed "real" robots of the transfer studies are study code
(``studies/concealed_robots.py``).
"""

from robolobe.tl.dataset import ModalDataset, TrustWarning, dataset_from_frame
from robolobe.tl.estimator import ModalPrediction, ModalPredictor, transfer_network
from robolobe.tl.graybox import TwinCalibration
from robolobe.tl.models import load_model
from robolobe.tl.presets import DEFAULT_PRESET, PRESETS
from robolobe.tl.residual import CorrectedTwin
from robolobe.tl.transfer import transfer

__all__ = [
    "DEFAULT_PRESET",
    "PRESETS",
    "CorrectedTwin",
    "ModalDataset",
    "ModalPrediction",
    "ModalPredictor",
    "TrustWarning",
    "TwinCalibration",
    "dataset_from_frame",
    "load_model",
    "transfer",
    "transfer_network",
]
