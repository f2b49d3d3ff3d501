"""``robolobe examples``: copy the bundled jobs and toolpaths into a folder."""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

from robolobe._text import count
from robolobe.cli._common import console
from robolobe.errors import InputError

__all__ = ["copy_examples", "register"]


def copy_examples(target: Path, *, force: bool = False) -> list[Path]:
    """Copy the bundled example jobs and toolpaths into ``target``.

    Parameters
    ----------
    target : pathlib.Path
        Folder to copy into (created if missing).
    force : bool
        Replace files of the same name; without it an existing file is an
        error and nothing is copied.

    Returns
    -------
    list of pathlib.Path
        The files written, sorted by name.

    Raises
    ------
    InputError
        ``target`` is not a usable folder, or (without ``force``) one of the
        example files already exists there.
    """
    from robolobe._atomic import atomic_path, check_output_dir

    check_output_dir(target, "DIR")
    base = resources.files("robolobe.data").joinpath("examples")
    names = sorted(
        e.name
        for e in base.iterdir()
        if e.is_file() and not e.name.startswith(("_", ".")) and e.name != "__init__.py"
    )
    clash = [n for n in names if (target / n).exists()]
    if clash and not force:
        raise InputError(
            f"{target / clash[0]} exists ({count(len(clash), 'example file')} would be replaced); "
            "expected a folder without them, or --force",
            source="DIR",
        )
    written = []
    for name in names:
        with resources.as_file(base.joinpath(name)) as src, atomic_path(target / name) as tmp:
            shutil.copyfile(src, tmp)
        written.append(target / name)
    return written


def register(app: typer.Typer) -> None:
    """Add the ``examples`` command to ``app``."""

    @app.command("examples")
    def examples_command(
        target: Annotated[Path, typer.Argument(help="Folder to copy the examples into.")] = Path(
            "robolobe-examples"
        ),
        force: Annotated[
            bool, typer.Option("--force", help="Replace example files already in the folder.")
        ] = False,
    ) -> None:
        """Copy the bundled example jobs and toolpaths (G-code, APT, RAPID, KRL) into a folder.

        The files are those `robolobe plan` uses with no arguments and those
        the README's commands name, e.g. `robolobe plan contour.apt --job
        job_B_contour.toml` run inside the folder.
        """
        files = copy_examples(target, force=force)
        console.print(
            f"{count(len(files), 'file')} -> {target}/: " + ", ".join(f.name for f in files),
            soft_wrap=True,
        )
