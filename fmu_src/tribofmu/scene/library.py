"""The scenes that ship with tribofmu (package data, ``tribofmu/scenarios/*.toml``) and how a
command-line argument names one: an existing file path, or a shipped scene's name.

    resolve_scene("fig2_dry")            # the shipped scene, from any folder, any install
    resolve_scene("my/own_scene.toml")   # a file
"""
from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

from ..errors import ScenarioError


def scenes_dir() -> Path:
    """The folder of the shipped scenes (inside the installed package)."""
    return Path(str(resources.files("tribofmu") / "scenarios"))


def scene_names() -> list[str]:
    """The shipped scenes' names, sorted."""
    return sorted(p.stem for p in scenes_dir().glob("*.toml"))


def scene_path(name: str) -> Path:
    """The file of the shipped scene ``name``; a ScenarioError listing the names otherwise."""
    path = scenes_dir() / f"{name}.toml"
    if not path.is_file():
        raise ScenarioError(f"no scene named {name!r} (shipped scenes: {', '.join(scene_names())}; "
                            "or give the path of a .toml file)")
    return path


def resolve_scene(arg: str | Path) -> Path:
    """A scenario argument as a file: a path with a folder part, or a file here, is itself; a
    bare name (with or without ``.toml``) that is not a file here is the shipped scene of that
    name (a folder here of that name, e.g. a run's output, does not hide the scene)."""
    path = Path(arg)
    if path.is_file() or len(path.parts) != 1:
        return path  # a path: the loader reports a missing or unreadable file
    name = path.name[:-5] if path.name.endswith(".toml") else path.name
    if path.exists() and not (scenes_dir() / f"{name}.toml").is_file():
        return path  # e.g. a FIFO or folder: the loader says what is wrong with it
    return scene_path(name)


def scene_summary(path: Path) -> str:
    """One line about a scene file: its title, or its first comment line."""
    try:
        text = path.read_text(encoding="utf-8")
        title = tomllib.loads(text).get("scenario", {}).get("title", "")
    except (OSError, ValueError):
        return "(unreadable)"
    if title:
        return str(title)
    for line in text.splitlines():
        if line.startswith("#"):
            return line.lstrip("# ").strip()
    return ""
