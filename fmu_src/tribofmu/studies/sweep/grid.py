"""The grid of a sweep: ``--grid`` values parsed, expanded into points, and every point's
scenario and the coupling settings validated on the client before any work (:func:`plan`).

Also how a point's values are written (sweep.csv, labels, file names) and compared: values
that are the same setting compare equal (10 == 10.0), so a resumed sweep finds its rows.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from typing import Any, Iterable

from ...errors import ScenarioError, SweepError
from ...scene.scenario import Scenario, _split_assignment, load_scenario, to_dict


def parse_grid(items: Iterable[str]) -> dict[str, list]:
    """``["drive.omega=10,20", "conditions.n=-10,-20"]`` -> ``{"drive.omega": [10, 20], ...}``.

    Values are read like ``--set`` values (TOML: numbers, true/false, ``[1, 2]`` arrays,
    otherwise a bare word); commas inside brackets or quotes do not split.
    """
    grid: dict[str, list] = {}
    for item in items:
        if "=" not in item:
            raise SweepError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        key, text = (s.strip() for s in item.split("=", 1))
        if not key:
            raise SweepError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        if key in grid:
            raise SweepError(f"--grid {key} is given twice")
        parts = _split_values(text)
        if not parts or any(p == "" for p in parts):
            raise SweepError(f"--grid {key}: empty value in {text!r}")
        grid[key] = [_split_assignment(f"{key}={p}", "--grid")[1] for p in parts]
    return grid


def _split_values(text: str) -> list[str]:
    parts, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    parts.append("".join(cur).strip())
    return parts


def grid_points(grid: dict[str, list]) -> list[dict[str, Any]]:
    """The cartesian product in grid order: the first key varies slowest."""
    keys = list(grid)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]


def format_value(value: Any) -> str:
    """A swept value as written in sweep.csv; read back by :func:`parse_value`."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return str(value)


def parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def same_setting(value: Any) -> Any:
    """Values that are the same setting compare equal: 10 == 10.0, [1, 2] == [1.0, 2.0]."""
    if isinstance(value, bool):
        return ("b", value)
    if isinstance(value, (int, float)):
        return ("n", float(value))
    if isinstance(value, (list, tuple)):
        return ("l", tuple(same_setting(v) for v in value))
    return ("s", str(value))


def is_numeric(values: list) -> bool:
    """All numbers (not booleans): the values can be an axis."""
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def point_key(point: dict[str, Any], keys: Iterable[str]) -> tuple:
    return tuple(same_setting(point[k]) for k in keys)


def point_label(point: dict[str, Any]) -> str:
    return ", ".join(f"{k}={format_value(v)}" for k, v in point.items())


def point_id(point: dict[str, Any]) -> str:
    text = json.dumps([[k, repr(same_setting(v))] for k, v in point.items()])
    return hashlib.sha1(text.encode()).hexdigest()[:16]


@dataclass
class Plan:
    """A validated sweep: the swept keys, the points and their scenarios in grid order, the
    base scenario and ``meta`` (what sweep.json records; a resumed sweep must match it)."""

    keys: list[str]
    points: list[dict[str, Any]]
    scenarios: list[Scenario]
    base: Scenario
    meta: dict[str, Any]


def plan(scenario_path, grid: dict[str, list], overrides, algorithm, step, tol) -> Plan:
    """Validate everything on the client: every grid point's scenario, the coupling settings."""
    if not grid:
        raise SweepError("nothing to sweep: give at least one --grid KEY=V1,V2,...")
    keys = list(grid)
    for key, values in grid.items():
        if not isinstance(values, (list, tuple)) or not values:
            raise SweepError(f"--grid {key} needs at least one value, got {values!r}")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(_split_assignment(item, "--set") for item in overrides)
    overrides = dict(overrides or {})
    both = [k for k in keys if k in overrides]
    if both:
        raise SweepError(f"{both[0]} is both swept (--grid) and set (--set)")
    base = load_scenario(scenario_path, overrides)
    for key, values in grid.items():  # each value alone first: the message names it
        for value in values:
            try:
                base.with_overrides({key: value})
            except ScenarioError as exc:
                raise SweepError(f"--grid {key}={format_value(value)}: {exc}") from None
        if len({same_setting(v) for v in values}) != len(values):
            raise SweepError(f"--grid {key} repeats a value: {', '.join(map(format_value, values))}")
    points = grid_points(grid)
    scenarios = []
    for point in points:
        try:
            scenarios.append(base.with_overrides(point))
        except ScenarioError as exc:
            raise SweepError(f"--grid point {point_label(point)}: {exc}") from None
    from ...coupling.algorithms import make_algorithm
    for value, name in ((step, "step"), (tol, "tol")):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise SweepError(f"--{name} must be > 0, got {value}")
    for sc in {(s.simulation.algorithm, s.simulation.step, s.simulation.tol) for s in scenarios}:
        name = algorithm or sc[0]
        try:
            make_algorithm(name, step=step if step is not None else sc[1], tol=tol if tol is not None else sc[2])
        except ValueError as exc:
            raise SweepError(f"--algorithm: {exc}") from None
    # every point must resolve its drive (the CLI checks the base scene alone): one line
    # naming the point, before any runs, instead of an ok row that does not resolve it
    from ...scene.checks import check_resolution
    from ...errors import UsageError
    for point, sc in zip(points, scenarios):
        try:
            check_resolution(sc, algorithm or sc.simulation.algorithm, step)
        except UsageError as exc:
            raise SweepError(f"--grid point {point_label(point)}: {exc}") from None
    meta = {"scenario": str(scenario_path), "base": _fingerprint(base, keys), "overrides":
            {k: format_value(v) for k, v in overrides.items()}, "algorithm": algorithm, "step": step,
            "tol": tol, "keys": keys, "grid": {k: [format_value(v) for v in vs] for k, vs in grid.items()}}
    return Plan(keys, points, scenarios, base, meta)


def _fingerprint(base: Scenario, keys: list[str]) -> str:
    data = to_dict(base)
    for key in keys:  # the swept values are per point, not part of the base
        table, _, name = key.partition(".")
        data.get(table, {}).pop(name, None)
    data.get("scenario", {}).pop("title", None)
    return hashlib.sha1(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()[:16]
