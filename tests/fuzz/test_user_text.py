"""User text that reaches the terminal or a report is shown as written (hypothesis).

The class: a file name, output path, robot name, job title or quoted file
content holding rich markup (``[/]``, ``[bold]``), emoji codes, ANSI escapes,
a right-to-left override, other control or bidi characters, or a newline
followed by a forged ``error:``. Each must print as its text (markup as
brackets, controls as their escapes), never crash the command, never style
or move the terminal and never add a line; in the HTML report it must be
escaped text. Names and titles read from files refuse hidden characters.
The references here are written for the test (Unicode categories and the
bidi list of Unicode TR 9), not taken from robolobe.
"""

from __future__ import annotations

import dataclasses
import unicodedata
from html.parser import HTMLParser
from importlib import resources
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe._text import html_text, visible
from robolobe.cli.main import main
from robolobe.errors import InputError

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
FUZZ = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

#: Unicode TR 9 explicit directional formatting characters.
BIDI = set("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")
FRAGMENTS = [
    "[/]", "[bold]", "[red]x[/red]", "[link=http://e.x]", ":smile:", "\\[", "[[joints]]",
    "\x1b[31m", "\x1b[2J", "\x1b]8;;http://e.x\x1b\\", "\x1b[1A", "\u202e", "\u2066", "\u200f",
    "\n", "\r", "\nerror: forged", "\rerror: over", "\t", "\x07", "\x08", "\x7f", "\x9b",
    "\u2028", "$x^2$", "<script>alert(1)</script>", "&amp;", "\"'", "résumé", "漢字",
]  # fmt: skip
plain = st.text(
    alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",), exclude_characters="/\0"),
    max_size=4,
)
hostile = st.lists(st.one_of(st.sampled_from(FRAGMENTS), plain), min_size=1, max_size=5).map(
    "".join
)
# a file name: no "/" or NUL, not "." or "..", not over the 255-byte limit
names = hostile.filter(lambda s: s not in (".", "..") and len(s.encode()) < 200).map(
    lambda s: s.replace("/", "_")
)


def _hidden(ch: str) -> bool:
    return unicodedata.category(ch) == "Cc" or ch in BIDI or ch in "\u2028\u2029"


def _assert_terminal_safe(text: str) -> None:
    bad = [ch for ch in text if _hidden(ch) and ch != "\n"]
    assert not bad, f"raw control characters {bad!r} reached the terminal: {text!r}"


@given(text=hostile)
@FUZZ
def test_visible_leaves_no_hidden_character(text: str) -> None:
    out = visible(text)
    assert not any(_hidden(ch) for ch in out), repr(out)
    for ch in set(text):
        if _hidden(ch):
            assert ascii(ch)[1:-1] in out  # each shows as its escape
        else:
            assert ch in out  # the rest as written
    kept = visible(text, newlines=True)
    assert kept.count("\n") == text.count("\n")
    assert not any(_hidden(ch) for ch in kept.replace("\n", ""))


@given(text=hostile)
@FUZZ
def test_html_text_is_inert(text: str) -> None:
    out = html_text(text)
    assert "<" not in out
    assert ">" not in out
    assert not any(_hidden(ch) for ch in out)
    parser = _Collect()
    parser.feed(f"<p>{out}</p>")
    assert parser.tags == ["p"]
    assert "".join(parser.data) == visible(text)


class _Collect(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.data: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)

    def handle_data(self, data: str) -> None:
        self.data.append(data)


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    code: int | str | None = 0
    try:
        main(argv)
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return int(code or 0), out, err


#: Commands whose input is missing: (argv with NAME for the input path).
MISSING_INPUT = [
    ["plan", "NAME", "--job", str(EX / "job_A_pocket.toml"), "-o", "OUT"],
    ["plan", str(EX / "pocket.nc"), "--job", "NAME", "-o", "OUT"],
    ["verify", "NAME", "--robot", "A", "-o", "OUT"],
    ["identify", "NAME", "-o", "OUT.csv"],
    ["sld", "--modes", "NAME", "--teeth", "2", "--immersion", "0.5", "--rpm", "5000:9000:20",
     "--material", "Al7075-T6", "-o", "OUT.csv"],
    ["predict", "A", "NAME", "-o", "OUT.csv"],
    ["simulate", "NAME", "--design", "seed", "-o", "OUT"],
]  # fmt: skip


@pytest.mark.parametrize("spec", MISSING_INPUT, ids=lambda s: " ".join(s[:2]))
@FUZZ
@given(name=names)
def test_missing_input_named_in_one_safe_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spec: list[str], name: str
) -> None:
    missing = tmp_path / "in" / name
    out = tmp_path / "out"
    argv = [
        str(missing) if a == "NAME" else str(out) + a.removeprefix("OUT") if a.startswith("OUT")
        else a
        for a in spec
    ]  # fmt: skip
    code, stdout, err = _run(argv, capsys)
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err  # a newline in the name forges no second line
    assert lines[0].startswith("error: "), lines[0]
    _assert_terminal_safe(err)
    assert visible(name) in lines[0]  # markup shows as written, controls as escapes
    assert not stdout.strip()
    assert not out.exists()
    assert not Path(str(out) + ".csv").exists()


MODES = "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1.34e6\nyy,1,922,0.011,1.34e6\n"


@FUZZ
@given(name=names)
def test_output_path_printed_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    modes = tmp_path / "m.csv"
    modes.write_text(MODES)
    target = tmp_path / f"{name}.csv"
    argv = ["sld", "--modes", str(modes), "--teeth", "2", "--immersion", "0.5",
            "--rpm", "5000:9000:20", "--material", "Al7075-T6", "-o", str(target)]  # fmt: skip
    code, stdout, err = _run(argv, capsys)
    assert code == 0, err
    assert target.is_file()
    _assert_terminal_safe(stdout + err)
    wrote = [ln for ln in stdout.splitlines() if ln.startswith("wrote ")]
    assert wrote == [f"wrote {visible(target)}"], stdout
    assert not any(ln.startswith("error") for ln in (stdout + err).splitlines())


@given(name=hostile.filter(lambda s: any(_hidden(ch) for ch in s)))
@FUZZ
def test_names_from_files_refuse_hidden_characters(tmp_path: Path, name: str) -> None:
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job
    from robolobe.robots import load_robot

    job = load_job(EX / "job_A_pocket.toml")
    for key in (("name",), ("robot", "name"), ("material", "name")):
        d = job_to_dict(job)
        parent = d
        for k in key[:-1]:
            parent = parent[k]
        parent[key[-1]] = name
        with pytest.raises(InputError, match="printable") as info:
            job_from_dict(d, source="j.toml")
        _assert_terminal_safe(str(info.value))
    text = resources.files("robolobe.data").joinpath("robots", "A.toml").read_text()
    f = tmp_path / "r.toml"
    f.write_text(
        "\n".join(
            f"name = {_toml_string(name)}" if ln.startswith("name =") else ln
            for ln in text.splitlines()
        )
    )
    with pytest.raises(InputError, match="printable") as info:
        load_robot(str(f))
    _assert_terminal_safe(str(info.value))


def _toml_string(text: str) -> str:
    """``text`` as a TOML basic string (controls as \\uXXXX escapes)."""
    out = []
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif unicodedata.category(ch) == "Cc":
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


@pytest.fixture(scope="module")
def plan_result():  # type: ignore[no-untyped-def]
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path

    return plan_path(EX / "pocket.nc", load_job(EX / "job_A_pocket.toml"), refine=False)


@given(text=hostile)
@FUZZ
def test_report_html_escapes_user_text(plan_result, text: str) -> None:  # type: ignore[no-untyped-def]
    from robolobe.plan.report import render_html

    s = dataclasses.replace(
        plan_result.summary, path=text, job=text, robot=text, mode_source=text, notes=(text,)
    )
    page = render_html(dataclasses.replace(plan_result, summary=s), {})
    assert not any(_hidden(ch) for ch in page.replace("\n", ""))
    parser = _Collect()
    parser.feed(page)
    assert "script" not in parser.tags
    shown = "".join(parser.data)
    assert visible(text) in shown


@pytest.mark.slow
def test_markup_job_title_prints_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    title = "Pocket [bold]x[/] [/] :smile: [robot]"
    text = (EX / "job_A_pocket.toml").read_text()
    job = tmp_path / "j.toml"
    job.write_text(text.replace('name = "Pocket', f'name = "{title}', 1))
    path = tmp_path / "p[bold]a[red]th.nc"
    path.write_text((EX / "pocket.nc").read_text())
    code, stdout, err = _run(
        [
            "plan", str(path), "--job", str(job), "-o", str(tmp_path / "o[/]"),
            "--no-plots", "--html",
        ],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    assert "p[bold]a[red]th.nc" in stdout
    assert "o[/]" in stdout
    report = (tmp_path / "o[/]" / "report.html").read_text()
    assert "Pocket [bold]x[/] [/] :smile: [robot]" in report


@pytest.mark.filterwarnings("ignore:Glyph")  # a character the font lacks: a box, not an error
@given(text=hostile | st.sampled_from([r"a$\frac$b", "$x$", "$$", r"\$", "$^$", r"$\undefined$"]))
@FUZZ
def test_plot_text_is_never_mathtext(text: str) -> None:
    """User text in a plot's legend or title draws as written (a ``$`` pair is no formula)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from robolobe._text import plot_text

    fig = Figure(figsize=(2, 2))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="x" + plot_text(text))  # "_..." labels are hidden
    ax.set_title(plot_text(text))
    ax.legend()
    FigureCanvasAgg(fig).draw()  # raises on a bad formula
    assert ax.get_title() == plot_text(text)
