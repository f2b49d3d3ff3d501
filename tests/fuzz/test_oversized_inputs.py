"""Inputs larger than the command can ever finish are refused up front (hypothesis).

The class: a postures file of more postures than a simulated campaign takes
(each posture is hours of hammer tests; 1,000 at most), given to ``simulate``:
one line naming the file, expected vs found, exit 2, nothing written, and no
simulation started (a 1.8-million-row file used to run for minutes).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.cli.main import main

FUZZ = settings(
    max_examples=3,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(n=st.integers(1001, 3000))
def test_simulate_refuses_more_postures_than_a_campaign(
    tmp_path: Path, n: int, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = "".join(f"P{i},0,10,-20,0,20,0\n" for i in range(n))
    postures = tmp_path / f"post{n}.csv"
    postures.write_text("posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n" + rows)
    out = tmp_path / f"camp{n}"
    capsys.readouterr()
    t0 = time.process_time()
    with pytest.raises(SystemExit) as info:
        main(["simulate", "B", "-o", str(out), "--postures", str(postures), "--dirs", "xx"])
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert f"post{n}.csv" in lines[0]
    assert f"expected 1 to 1000 postures, found {n}" in lines[0]
    assert not out.exists()
    assert time.process_time() - t0 < 20.0
