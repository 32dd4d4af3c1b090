"""The arguments of the Python API's calls (:mod:`tribofmu.api`), checked at the door: a wrong
type or a value out of range is an :class:`~tribofmu.errors.ArgumentError`, one line naming the
call and the argument, raised before any FMU is found or built or any file written. What a run
asks of its scene (step, tol, the algorithm, the drive) is checked with the scene, in
:mod:`tribofmu.scene.checks`.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

from .errors import ArgumentError, UsageError
from .scene.checks import check_max_wall, shown
from .scene.scenario import Scenario

# max_wall's default: the scene's own limit (simulation.max_wall)
SCENE_MAX_WALL = "scene"


def arguments(call: str, check):
    """``check()``'s answer; its refusal of an argument (a UsageError) as an ArgumentError
    naming the call."""
    try:
        return check()
    except ArgumentError:
        raise
    except UsageError as exc:
        raise ArgumentError(f"api.{call}: {exc}") from None


def refuse(call: str, name: str, wanted: str, value) -> None:
    raise ArgumentError(f"api.{call}: {name} must be {wanted}, got {shown(value)}"
                        f"{'' if value is None else f' ({type(value).__name__})'}")


def check_path(call: str, name: str, value, optional: bool = False) -> None:
    if optional and value is None:
        return
    if not isinstance(value, (str, os.PathLike)) or (isinstance(value, str) and not value.strip()):
        refuse(call, name, "a path (str or os.PathLike)" + (" or None" if optional else ""), value)


def check_scenario(call: str, value) -> None:
    if not isinstance(value, Scenario):
        try:
            check_path(call, "scenario", value)
        except ArgumentError:
            refuse(call, "scenario", "a Scenario (api.load), a shipped scene's name or a .toml path", value)


def check_overrides(call: str, overrides) -> None:
    """None, a mapping of ``"table.key"`` strings to values, or a list of ``"KEY=VALUE"`` strings."""
    wanted = "a mapping {'table.key': value} or a list of 'KEY=VALUE' strings"
    if overrides is None:
        return
    if isinstance(overrides, Mapping):
        bad = next((k for k in overrides if not isinstance(k, str)), None)
        if bad is not None:
            refuse(call, "overrides' key", "a string 'table.key'", bad)
    elif isinstance(overrides, (list, tuple)):
        bad = next((item for item in overrides if not isinstance(item, str) or "=" not in item), None)
        if bad is not None:
            refuse(call, "an item of overrides", "a 'KEY=VALUE' string", bad)
    else:
        refuse(call, "overrides", wanted, overrides)


def check_flag(call: str, name: str, value, optional: bool = False) -> None:
    if not (isinstance(value, bool) or (optional and value is None)):
        refuse(call, name, "True or False" + (" or None" if optional else ""), value)


def check_callable(call: str, name: str, value) -> None:
    if value is not None and not callable(value):
        refuse(call, name, "a callable or None", value)


def check_run_arguments(call: str, scenario, overrides, fmu_dir, build, progress, notice, max_wall,
                        **flags) -> None:
    """The arguments :func:`~tribofmu.api.simulate` and :func:`~tribofmu.api.simulate_and_save` share (but step, tol and
    algorithm, which :func:`~tribofmu.scene.checks.check_run` checks with the scene)."""
    check_scenario(call, scenario)
    check_overrides(call, overrides)
    check_path(call, "fmu_dir", fmu_dir, optional=True)
    check_flag(call, "build", build, optional=True)
    for name, value in flags.items():
        if name == "sink":
            check_callable(call, name, value)
        else:
            check_flag(call, name, value)
    check_callable(call, "progress", progress)
    check_callable(call, "notice", notice)
    if not (isinstance(max_wall, str) and max_wall == SCENE_MAX_WALL):
        arguments(call, lambda: check_max_wall(max_wall, "max_wall"))
