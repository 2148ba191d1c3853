"""Where the shipped data lives: ``conf/`` (the Hydra configs) and ``policies/`` (the shipped policy).

In a source tree or an editable install they sit beside the package (the repository's
``conf/`` and ``policies/``); a wheel ships them inside it as package data
(``explore_rl/conf``, ``explore_rl/policies``; pyproject.toml maps the folders there).
The copy inside the package wins, then the repository's. Imports nothing of the package.
"""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """The shipped folder ``name`` (``conf`` or ``policies``): inside the installed package,
    else beside it in the source tree. FileNotFoundError (naming both places) if neither."""
    candidates = (PACKAGE_DIR / name, PACKAGE_DIR.parent / name)
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"explore_rl's {name}/ folder is missing (looked in {candidates[0]} and "
                            f"{candidates[1]}): reinstall the package")


def conf_dir() -> Path:
    """The Hydra config directory (``conf/``)."""
    return data_dir("conf")


def shipped_file(relative: str | Path) -> Path:
    """A file under the shipped ``policies/`` given as ``policies/...`` (e.g. the default
    ``policies/buildings_dagger_em_choice/actor.pt``)."""
    relative = Path(relative)
    parts = relative.parts[1:] if relative.parts[:1] == ("policies",) else relative.parts
    return data_dir("policies").joinpath(*parts)
