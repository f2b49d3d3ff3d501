"""The documentation site builds, and every gallery example runs.

The site (``mkdocs.yml``, ``docs/``) is built with ``mkdocs build --strict``
(broken links, missing snippet files and docstrings mkdocstrings cannot
render fail it). Each gallery script in ``examples/gallery/`` is run as a
user would run it, ``python examples/gallery/NAME.py OUTDIR``, and its
printed numbers and written files are checked.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "examples" / "gallery"
SCRIPTS = sorted(p.stem for p in GALLERY.glob("*.py"))


def _env() -> dict[str, str]:
    env = dict(os.environ)
    src = str(ROOT / "src")
    env["PYTHONPATH"] = os.pathsep.join([src, env["PYTHONPATH"]]) if env.get("PYTHONPATH") else src
    env["NO_MKDOCS_2_WARNING"] = "1"
    env.setdefault("MPLBACKEND", "Agg")
    return env


def _run(args: list[str], what: str) -> str:
    proc = subprocess.run(
        [sys.executable, *args], cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, f"{what} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def _run_gallery(name: str, out: Path) -> str:
    return _run([str(GALLERY / f"{name}.py"), str(out)], f"{name}.py")


def test_every_gallery_script_has_a_page_in_the_nav() -> None:
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert len(SCRIPTS) >= 4
    for name in SCRIPTS:
        page = ROOT / "docs" / "gallery" / f"{name}.md"
        assert page.is_file(), f"examples/gallery/{name}.py has no page docs/gallery/{name}.md"
        assert f'--8<-- "examples/gallery/{name}.py"' in page.read_text(encoding="utf-8")
        assert f"gallery/{name}.md" in nav, f"docs/gallery/{name}.md is not in mkdocs.yml's nav"


@pytest.mark.slow
def test_docs_build_strict(tmp_path: Path) -> None:
    needed = ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers")
    missing = [m for m in needed if importlib.util.find_spec(m) is None]
    if missing:
        pytest.skip(f"docs tools not installed ({', '.join(missing)}): pip install -e '.[docs]'")
    site = tmp_path / "site"
    _run(["-m", "mkdocs", "build", "--strict", "--site-dir", str(site)], "mkdocs build --strict")
    # The API reference was rendered from the docstrings, not left empty.
    api = (site / "api" / "plan.html").read_text(encoding="utf-8")
    assert "load_job" in api
    assert "robolobe-job/1" in api
    sld = (site / "api" / "sld.html").read_text(encoding="utf-8")
    assert "stability_lobes" in sld
    assert "Natural frequencies" in sld
    # The gallery pages carry the scripts' code (snippets resolved).
    page = (site / "gallery" / "campaign_to_plan.html").read_text(encoding="utf-8")
    assert "TwinCalibration" in page
    assert (site / "img" / "lobes_one_tool_point.png").stat().st_size > 1000
    # The site browses from disk (site/index.html): every link of every page leads to a
    # file, not to a folder a browser would show as a listing.
    assert _broken_links(site) == []
    nav = _links(site / "index.html")
    assert "guide/job.html" in nav
    assert "api/plan.html" in nav


def _links(page: Path) -> list[str]:
    """The href and src values of an HTML page."""
    from html.parser import HTMLParser

    class Links(HTMLParser):
        def __init__(self) -> None:
            super().__init__()
            self.found: list[str] = []

        def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
            self.found += [v for k, v in attrs if k in ("href", "src") and v]

    parser = Links()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser.found


def _broken_links(site: Path) -> list[str]:
    """'page -> link' for each relative link of the built site that is not a file.

    The 404 page is left out: a server shows it for any missing URL, so its links
    are written from the site's root.
    """
    from urllib.parse import unquote, urlsplit

    broken = []
    for page in sorted(site.rglob("*.html")):
        if page.name == "404.html":
            continue
        for link in _links(page):
            url = urlsplit(link)
            if url.scheme or url.netloc or not url.path:  # another site, or this page
                continue
            if not (page.parent / unquote(url.path)).is_file():
                broken.append(f"{page.relative_to(site)} -> {link}")
    return broken


def test_broken_links_are_found(tmp_path: Path) -> None:
    """The link check above finds a link to a folder and to a missing file."""
    (tmp_path / "guide").mkdir()
    (tmp_path / "guide" / "job.html").write_text("<p>job</p>", encoding="utf-8")
    (tmp_path / "index.html").write_text(
        '<a href="guide/job.html#keys">ok</a><a href="https://x.org/">ext</a><a href="#top">'
        '</a><a href="guide/">dir</a><img src="img/missing.png">',
        encoding="utf-8",
    )
    assert _broken_links(tmp_path) == ["index.html -> guide/", "index.html -> img/missing.png"]


def test_gallery_lobes_one_tool_point(tmp_path: Path) -> None:
    out = _run_gallery("lobes_one_tool_point", tmp_path)
    a_min = float(re.search(r"smallest stable depth in the range: ([\d.]+) mm", out).group(1))  # type: ignore[union-attr]
    a_best = float(re.search(r"stable up to ([\d.]+) mm", out).group(1))  # type: ignore[union-attr]
    assert 0 < a_min < a_best
    rows = (tmp_path / "lobes.csv").read_text(encoding="utf-8").splitlines()
    assert rows[0] == "rpm,a_lim_mm"
    assert len(rows) == 401
    depths = [float(r.split(",")[1]) for r in rows[1:]]
    assert min(depths) == pytest.approx(a_min, abs=0.01)
    assert (tmp_path / "lobes.png").stat().st_size > 1000


@pytest.mark.slow
def test_gallery_plan_bundled_pocket(tmp_path: Path) -> None:
    out = _run_gallery("plan_bundled_pocket", tmp_path)
    plan = tmp_path / "pocket_plan"
    summary = json.loads((plan / "summary.json").read_text(encoding="utf-8"))
    assert f"depth per pass: {summary['depth_mm']:.2f} mm" in out
    assert summary["min_margin"] >= summary["safety_factor"] - 1e-6
    for name in ("waypoints.csv", "report.html", "plots/lobes.png"):
        assert (plan / name).is_file(), name


@pytest.mark.slow
def test_gallery_compare_robots_for_a_job(tmp_path: Path) -> None:
    out = _run_gallery("compare_robots_for_a_job", tmp_path)
    table = (tmp_path / "compare" / "compare.csv").read_text(encoding="utf-8")
    for robot in ("A", "B", "C"):
        assert re.search(rf"^\s*{robot}\s+ok\s", out, re.M), out
        assert (tmp_path / "compare" / robot / "summary.json").is_file(), robot
        assert re.search(rf"^{robot},", table, re.M), table


@pytest.mark.slow
def test_gallery_campaign_to_plan(tmp_path: Path) -> None:
    out = _run_gallery("campaign_to_plan", tmp_path)
    # The hidden truth is a joint-2 stiffness 0.75 x the robot file's value.
    k2 = float(re.search(r"^\s*k2\s+([\d.]+)\s+x", out, re.M).group(1))  # type: ignore[union-attr]
    assert k2 == pytest.approx(0.75, abs=0.03)
    for name in ("campaign/frf.csv", "modal.csv", "B_calibrated.toml", "contour_plan/summary.json"):
        assert (tmp_path / name).is_file(), name


@pytest.mark.slow
def test_gallery_diagnose_campaign(tmp_path: Path) -> None:
    out = _run_gallery("diagnose_campaign", tmp_path)
    # The hidden truth is a 6 kg mass at the tool point.
    assert "verdict: added_mass" in out
    mass = float(re.search(r"mass_kg = ([\d.]+)", out).group(1))  # type: ignore[union-attr]
    assert mass == pytest.approx(6.0, rel=0.1)
    assert (tmp_path / "diagnosis" / "index.html").is_file()
