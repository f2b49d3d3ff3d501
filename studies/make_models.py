"""(Re)make the shipped models ``src/robolobe/data/models/{A,B,C}.npz``.

Robot A: the seed design's 254 postures; robot B: its 20 training postures;
robot C: its 20 one-sided + the paper's 4 added postures (24). Data: the
twin's identified-like modal datasets (robolobe.tl.twin_data: 5 lowest modes
per direction, unseen modes missing, identification noise). Model: the
``"improved"`` preset (robolobe.tl.presets), A pretrained with the seed's
80:20 split (the 20 % calibrate the spread), B and C transferred from A with
3 frozen layers and 5-fold cross-validated spread calibration.

Deterministic from ``--seed`` (one torch thread: bitwise repeatable on the
same machine). Run from the repository root:

    python studies/make_models.py [--seed 0] [--out src/robolobe/data/models]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
import torch

from robolobe._atomic import atomic_write_text
from robolobe.robots import load_robot
from robolobe.tl.estimator import ModalPredictor
from robolobe.tl.presets import DEFAULT_PRESET, PRESETS
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin.designs import DEFAULT_SEED, design_arrays, seed_design
from robolobe.twin.model import Twin


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--preset", default=DEFAULT_PRESET)
    ap.add_argument("--out", default="src/robolobe/data/models")
    args = ap.parse_args()
    torch.set_num_threads(1)
    out = Path(args.out)
    params = dict(PRESETS[args.preset])
    info: dict[str, object] = {
        "preset": args.preset,
        "seed": args.seed,
        "design_seed": DEFAULT_SEED,
        "data": "twin modes, 5 lowest per direction, unseen (visibility < 0.03) missing, "
        "identification noise f 0.1 %, zeta 3 %, k 2 % (robolobe.tl.twin_data)",
        "torch": torch.__version__,
        "machine": platform.machine(),
        "models": {},
    }
    source = None
    for key, roles in (("A", ("train",)), ("B", ("train",)), ("C", ("train", "added"))):
        ids, q, role = design_arrays(seed_design(key))
        keep = np.isin(np.asarray(role), roles)
        twin = Twin(load_robot(key))
        ds = twin_modal_dataset(
            twin,
            [i for i, k in zip(ids, keep, strict=True) if k],
            q[keep],
            rng=np.random.default_rng(args.seed + ord(key)),
        )
        t0 = time.perf_counter()
        if source is None:
            model = ModalPredictor(
                **params, calibration="holdout", robot=key, random_state=args.seed
            ).fit_dataset(ds)
            source = model
        else:
            model = ModalPredictor(
                **params, source=source, calibration="cv", robot=key, random_state=args.seed
            ).fit_dataset(ds)
        dt = time.perf_counter() - t0
        path = model.save(out / f"{key}.npz")
        info["models"][key] = {  # type: ignore[index]
            "postures": int(keep.sum()),
            "roles": list(roles),
            "lineage": model.lineage_,
            "n_frozen": model.n_frozen_used_,
            "calibration": np.round(model.calibration_, 4).tolist(),
            "train_seconds": round(dt, 1),
            "bytes": path.stat().st_size,
        }
        print(f"{key}: {int(keep.sum())} postures, {dt:.1f} s -> {path}")
    atomic_write_text(out / "models.json", json.dumps(info, indent=1) + "\n")


if __name__ == "__main__":
    main()
