"""The size dispatch of the compiled kernels (:func:`robolobe._jit.use_compiled`).

A small plan must take the numpy (Python) paths without importing numba at
all (its start-up costs more than such a plan's work); a large one the
compiled kernels; both give the same results.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe import _jit
from robolobe.stock import _kernels

SRC = Path(__file__).resolve().parents[1] / "src"


def _python(code: str, **env: str) -> subprocess.CompletedProcess[str]:
    """``code`` in a fresh interpreter on this checkout's sources."""
    e = {**os.environ, "PYTHONPATH": str(SRC), **env}
    e.pop("ROBOLOBE_NO_JIT", None)
    e.update(env)
    return subprocess.run(
        [sys.executable, "-c", code], env=e, capture_output=True, text=True, timeout=300
    )


def test_below_the_threshold_numba_is_not_asked_for(monkeypatch):
    def refuse() -> bool:
        raise AssertionError("available() imports numba: it must not be called below the size")

    monkeypatch.setattr(_jit, "_STATE", {})
    monkeypatch.setattr(_jit, "_SPENT", [0.0])
    monkeypatch.setattr(_jit, "available", refuse)
    assert not _jit.use_compiled(400, cold=1000, warm=10)
    # where numba has started, the smaller threshold applies
    monkeypatch.setattr(_jit, "_STATE", {"started": True})
    assert not _jit.use_compiled(9, cold=1000, warm=10)
    monkeypatch.setattr(_jit, "available", lambda: True)
    assert _jit.use_compiled(10, cold=1000, warm=10)
    assert not _jit.use_compiled(999, cold=1000, warm=2000)  # never above the cold one
    assert _jit.use_compiled(1000, cold=1000, warm=2000)
    monkeypatch.setattr(_jit, "_STATE", {})
    assert _jit.use_compiled(1000, cold=1000, warm=10)
    monkeypatch.setattr(_jit, "available", lambda: False)  # ROBOLOBE_NO_JIT or no numba
    assert not _jit.use_compiled(1e12, cold=1000, warm=10)


def test_small_calls_start_numba_once_they_add_up_to_its_start_up(monkeypatch):
    """Each numpy call counts ``work / cold`` of numba's start-up; the call that would
    bring the sum to one start-up runs compiled (a process never pays more than
    about twice the better choice)."""
    asked = []

    def available() -> bool:
        asked.append(1)
        return True

    monkeypatch.setattr(_jit, "_STATE", {})
    monkeypatch.setattr(_jit, "_SPENT", [0.0])
    monkeypatch.setattr(_jit, "available", available)
    # 0.25 + 0.25 + 0.25 of the start-up on the numpy path (two kernels' own units)
    assert not _jit.use_compiled(250, cold=1000, warm=10)
    assert not _jit.use_compiled(25, cold=100, warm=1)
    assert not _jit.use_compiled(250, cold=1000, warm=10)
    assert asked == []
    assert _jit._SPENT[0] == 0.75
    assert _jit.use_compiled(250, cold=1000, warm=10)  # 1.0: as much as the start-up
    assert asked == [1]


def test_engagement_work_counts_swept_cells_and_samples():
    # one 100 mm cutting move of a 20 mm cutter at 0.5 mm cells, after a rapid move:
    # band 2 (10 + 0.75) mm = 21.5 mm -> 100 x 21.5 / 0.25 = 8,600 cells; samples every
    # 5 mm: 20 + 1 = 21, at 280 cells each = 5,880
    xyz = np.array([[0.0, 0.0, 0.05], [0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
    cut = np.array([False, False, True])
    assert _kernels.work(xyz, cut, 0.01, 0.0005) == pytest.approx(8_600 + 5_880, rel=1e-12)
    assert _kernels.work(xyz[:1], cut[:1], 0.01, 0.0005) == 0.0
    # the rapid move alone (cut on none) costs nothing
    assert _kernels.work(xyz, np.zeros(3, bool), 0.01, 0.0005) == 0.0


def test_bundled_plan_does_not_import_numba(tmp_path):
    """``robolobe plan`` (the bundled pocket on robot A) plans on the numpy paths:
    numba, llvmlite and no compiled kernel module are loaded."""
    code = (
        "import json, sys\n"
        "from robolobe.cli.main import main\n"
        "try:\n"
        f"    main(['plan', '-o', {str(tmp_path / 'out')!r}, '--no-plots', '--no-html'])\n"
        "except SystemExit as exc:\n"
        "    assert not exc.code, exc.code\n"
        "mods = sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'llvmlite')\n"
        "              or m.endswith('_kernels') and m != 'robolobe.stock._kernels')\n"
        "print(json.dumps({'mods': mods}))\n"
    )
    out = _python(code)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert (tmp_path / "out" / "waypoints.csv").stat().st_size > 10_000  # the plan ran
    assert got["mods"] == []


def test_compiled_engagement_equals_the_python_kernels():
    """The Z-map engagement of the bundled pocket and of a zig-zag of tiny moves: the
    Python kernels (below the size, in a fresh process) and the compiled ones (forced
    afterwards in the same process) give the same arrays, bit for bit."""
    pytest.importorskip("numba")
    code = (
        "import json, sys, numpy as np\n"
        "from robolobe import _jit\n"
        "from robolobe.cli.plan import example_files\n"
        "from robolobe.plan.paths import read_toolpath\n"
        "from robolobe.stock import _kernels, compute_engagement, default_stock\n"
        "wp = read_toolpath(example_files()[0])\n"
        "paths = [(wp[['x_m', 'y_m', 'z_m']].to_numpy(), (wp['motion'] == 'cut').to_numpy())]\n"
        "t = np.linspace(0.0, 1.0, 400)\n"
        "zz = np.stack([0.03 * np.sin(7 * t), 0.04 * t, np.where(t < 0.5, 0.0, -0.001)], -1)\n"
        "paths.append((zz, np.r_[False, np.ones(399, bool)]))\n"
        "res = []\n"
        "for xyz, cut in paths:\n"
        "    assert _kernels.work(xyz, cut, 0.01, 0.0005) < _kernels.JIT_MIN_WORK\n"
        "    _jit._SPENT[0] = 0.0  # each alone: below the size, not counted together\n"
        "    st = default_stock(xyz, cut, 0.01)\n"
        "    res.append([compute_engagement(xyz, cut, 0.02, st)])\n"
        "python_only = 'numba' not in sys.modules\n"
        "_kernels.JIT_MIN_WORK = 0.0\n"
        "for (xyz, cut), r in zip(paths, res):\n"
        "    r.append(compute_engagement(xyz, cut, 0.02, default_stock(xyz, cut, 0.01)))\n"
        "same = []\n"
        "for a, b in res:\n"
        "    for name in ('phi_entry', 'phi_exit', 'n_arcs', 'depth_m', 'plunge'):\n"
        "        same.append(np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True))\n"
        "engaged = [int((r[0].n_arcs > 0).sum()) for r in res]\n"
        "print(json.dumps({'python_only': python_only, 'compiled': 'numba' in sys.modules,\n"
        "                  'same': same, 'engaged': engaged}))\n"
    )
    out = _python(code)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["python_only"]
    assert got["compiled"]
    assert all(got["same"]), got["same"]
    assert min(got["engaged"]) > 50  # both paths cut material on many moves
