"""Plan many toolpaths with one job: a local process pool or a Dask cluster.

:func:`batch_plan` runs :func:`robolobe.plan.pipeline.plan_path` on every
path, in a joblib/loky process pool by default or on a Dask distributed
cluster when given a scheduler address (``dask[distributed]`` is an extra).
Each task uses one thread (BLAS, torch). A path that fails (bad file,
unreachable, infeasible) becomes a row with its status and message; the
others go on. Results arrive as they finish (for a progress bar) and end up
in one table, one row per path, with provenance (robolobe version, job file
and its SHA-256, path SHA-256, host, process, UTC time).
:func:`write_batch` writes it atomically as Parquet (pyarrow) or CSV.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import logging
import os
import platform
import socket
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from robolobe._atomic import SafeNames, atomic_dir, check_inside, unique_names
from robolobe._workers import MAX_WORKERS
from robolobe.errors import (
    EXIT_INFEASIBLE,
    EXIT_INPUT,
    InfeasibleError,
    InputError,
    ReachabilityError,
    RobolobeError,
)
from robolobe.plan.job import Job

__all__ = ["BATCH_COLUMNS", "BATCH_FILES", "batch_plan", "path_folders", "plan_one", "write_batch"]

logger = logging.getLogger(__name__)

BATCH_COLUMNS: tuple[str, ...] = (
    "path",
    "status",
    "exit_code",
    "message",
    "robot",
    "mode_source",
    "n_waypoints",
    "n_cut",
    "depth_mm",
    "rpm_min",
    "rpm_max",
    "mrr_cm3_per_min",
    "cycle_time_s",
    "min_margin",
    "min_margin_at",
    "method",
    "gain_vs_constant_pct",
    "gain_vs_programmed_pct",
    "elapsed_s",
    "robolobe_version",
    "job_file",
    "job_sha256",
    "path_sha256",
    "host",
    "pid",
    "finished_utc",
    "output_folder",
)
#: The batch's own files in its output folder (a path's folder never takes these names).
BATCH_FILES: tuple[str, ...] = ("batch.csv", "batch.parquet")


def path_folders(paths: Sequence[str | os.PathLike[str]]) -> SafeNames:
    """The per-path output folder names of a batch (``--per-path``), in input order.

    Each path's file stem made a safe folder name
    (:func:`robolobe._atomic.safe_name`: ``...nc`` -> ``path``); a name that
    repeats (``a/p.nc``, ``b/p.nc``) gets ``-2``, ``-3`` ...; the notes say
    which paths do not write to their stem.
    """
    items = [str(p) for p in paths]
    return unique_names(
        [Path(p).stem for p in items],
        what="toolpath",
        fallback="path",
        taken=BATCH_FILES,
        labels=items,
    )


def _sha256(path: str) -> str:
    try:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        return h.hexdigest()
    except OSError:
        return ""


def _one_thread() -> None:
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:  # pragma: no cover - torch is a dependency
        pass


def plan_one(
    path: str, job: Job, out_dir: str | None = None, refine: bool = True, folder: str | None = None
) -> dict[str, Any]:
    """Plan one path; never raises for a bad path (the row says what happened).

    Parameters
    ----------
    path : str
        Toolpath file.
    job : Job
    out_dir : str, optional
        When given, the full plan outputs (without HTML) go to
        ``out_dir/<folder>/``.
    refine : bool
        casadi refinement.
    folder : str, optional
        The path's folder in ``out_dir`` (:func:`path_folders` of the whole
        batch); default: that of this path alone.

    Returns
    -------
    dict
        One row of the batch table (:data:`BATCH_COLUMNS`).
    """
    import robolobe

    _one_thread()
    t0 = time.perf_counter()
    row: dict[str, Any] = {c: None for c in BATCH_COLUMNS}
    row.update(
        path=str(path),
        robolobe_version=robolobe.__version__,
        job_file=job.source,
        job_sha256=_sha256(job.source) if os.path.isfile(job.source) else "",
        path_sha256=_sha256(str(path)),
        host=socket.gethostname(),
        pid=os.getpid(),
    )
    try:
        from robolobe.plan.pipeline import plan_path

        res = plan_path(path, job, refine=refine)
        s = res.summary
        vs_const, vs_prog = s.vs_best_constant_speed, s.vs_programmed_speed
        row.update(
            status="ok",
            exit_code=0,
            message="; ".join(s.notes),
            robot=s.robot,
            mode_source=s.mode_source,
            n_waypoints=s.n_waypoints,
            n_cut=s.n_cut,
            depth_mm=s.depth_mm,
            rpm_min=s.rpm_min,
            rpm_max=s.rpm_max,
            mrr_cm3_per_min=s.mrr_cm3_per_min,
            cycle_time_s=s.cycle_time_s,
            min_margin=s.min_margin,
            min_margin_at=s.min_margin_at.source,
            method=s.method,
            gain_vs_constant_pct=vs_const.mrr_gain_pct if vs_const is not None else None,
            gain_vs_programmed_pct=vs_prog.mrr_gain_pct if vs_prog is not None else None,
        )
        if out_dir is not None:
            from robolobe.plan.report import write_outputs

            name = folder if folder is not None else path_folders([path]).names[0]
            target = Path(out_dir) / name
            check_inside(out_dir, target)
            write_outputs(res, target, plots=True, html_report=False)
            row["output_folder"] = name
    except InfeasibleError as exc:
        row.update(status="infeasible", exit_code=EXIT_INFEASIBLE, message=str(exc))
    except ReachabilityError as exc:
        row.update(status="unreachable", exit_code=EXIT_INPUT, message=str(exc))
    except RobolobeError as exc:
        row.update(status="error", exit_code=exc.exit_code, message=str(exc))
    except Exception as exc:  # a bug in one path must not stop the batch
        logger.exception("unexpected error planning %s", path)
        row.update(
            status="error", exit_code=1, message=f"internal error: {type(exc).__name__}: {exc}"
        )
    row["elapsed_s"] = round(time.perf_counter() - t0, 4)
    row["finished_utc"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    return row


def batch_plan(
    paths: Sequence[str | os.PathLike[str]],
    job: Job,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    out_dir: str | None = None,
    refine: bool = True,
    client: Any = None,
) -> Iterator[dict[str, Any]]:
    """Plan every path; yield one row per path as each finishes.

    Parameters
    ----------
    paths : sequence of path-like
    job : Job
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); default: a local
        process pool.
    workers : int, optional
        Processes of the local pool (default: CPU count); ignored with Dask.
    out_dir : str, optional
        Per-path plan outputs under ``out_dir/<folder>/`` (:func:`path_folders`).
    refine : bool
        casadi refinement.
    client : distributed.Client, optional
        An existing Dask client (overrides ``scheduler``; tests).

    Yields
    ------
    dict
        Rows of :data:`BATCH_COLUMNS`, in completion order.

    Raises
    ------
    InputError
        No paths, or Dask requested but not installed / not reachable.
    """
    items = [str(p) for p in paths]
    if not items:
        raise InputError("expected at least one toolpath, found none")
    folders = path_folders(items).names
    if scheduler is not None or client is not None:
        yield from _dask(items, folders, job, scheduler, client, out_dir, refine)
        return
    if workers is not None and (int(workers) != workers or not 1 <= workers <= MAX_WORKERS):
        raise InputError(f"workers: expected an integer 1 to {MAX_WORKERS}, found {workers!r}")
    # never more processes than paths: each extra one only costs its start-up
    n = min(workers or os.cpu_count() or 1, len(items))
    if n == 1:
        for p, f in zip(items, folders, strict=True):
            yield plan_one(p, job, out_dir, refine, f)
        return
    from joblib import Parallel, delayed, parallel_config

    with parallel_config(backend="loky", inner_max_num_threads=1):
        gen = Parallel(n_jobs=n, return_as="generator_unordered")(
            delayed(plan_one)(p, job, out_dir, refine, f)
            for p, f in zip(items, folders, strict=True)
        )
        yield from gen


def _dask(
    items: list[str],
    folders: Sequence[str],
    job: Job,
    scheduler: str | None,
    client: Any,
    out_dir: str | None,
    refine: bool,
) -> Iterator[dict[str, Any]]:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise InputError(
            "--scheduler needs dask.distributed: pip install 'robolobe[dask]'"
        ) from None
    own = client is None
    if own:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(
                f"cannot connect to the Dask scheduler: {exc}", source=str(scheduler)
            ) from None
    try:
        futures = [
            client.submit(plan_one, p, job, out_dir, refine, f, pure=False)
            for p, f in zip(items, folders, strict=True)
        ]
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        if own:
            client.close()


def write_batch(
    rows: Sequence[dict[str, Any]], out_dir: str | os.PathLike[str], *, fmt: str = "auto"
) -> Path:
    """Write the batch table atomically: ``batch.parquet`` (pyarrow) or ``batch.csv``.

    Parameters
    ----------
    rows : sequence of dict
    out_dir : path-like
    fmt : {"auto", "parquet", "csv"}
        ``auto``: Parquet when pyarrow is installed.

    Returns
    -------
    Path
        The table file.
    """
    df = pd.DataFrame(list(rows)).reindex(columns=list(BATCH_COLUMNS))
    df = df.sort_values("path", kind="stable").reset_index(drop=True)
    if fmt == "auto":
        try:
            import pyarrow  # noqa: F401

            fmt = "parquet"
        except ImportError:
            fmt = "csv"
    out = Path(out_dir)
    name = "batch.parquet" if fmt == "parquet" else "batch.csv"
    meta = {
        "python": platform.python_version(),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }
    with atomic_dir(out, "batch", option="--output") as tmp:
        if fmt == "parquet":
            for c in ("exit_code", "pid", "n_waypoints", "n_cut"):
                df[c] = pd.to_numeric(df[c], errors="coerce").astype("Int64")
            df.attrs.update(meta)
            df.to_parquet(tmp / name, index=False)
        else:
            df.to_csv(tmp / name, index=False)
    return out / name
