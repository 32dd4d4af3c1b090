"""docs/layout.md names every module under ``fmu_src/tribofmu`` and no module that is gone.

The page's map is the code block that starts with ``fmu_src/tribofmu/``: one entry a top-level
folder or module (the lines indented two spaces, each entry running on until the next). A module
``<folder>/.../<file>`` is named when its entry (the one whose head names ``<folder>/``) writes a
path that ends the module's path (``embedded.py``, ``laws/dry.py``, ``coupling/embedded.py``)
and ends no other module's path in that folder; a top-level module (``api.py``) when any entry
writes its file name. Modules are the ``.py`` files and the native loader's C sources; a
package's ``__init__.py`` counts as a module of its own only when it defines a function or a
class (otherwise naming the folder names it).
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

from scenes import ROOT

PACKAGE = ROOT / "fmu_src" / "tribofmu"
LAYOUT = ROOT / "docs" / "layout.md"
SOURCE_SUFFIXES = (".py", ".c", ".h")
WRITTEN = re.compile(r"(?<![\w/.<>-])([\w/]+\.(?:py|c|h))\b")


def defines_something(init: Path) -> bool:
    tree = ast.parse(init.read_text(encoding="utf-8"))
    return any(isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) for node in tree.body)


def modules(package: Path = PACKAGE) -> list[str]:
    """The package's modules, as paths relative to ``package`` (``coupling/embedded.py``)."""
    out = []
    for path in sorted(package.rglob("*")):
        if path.suffix not in SOURCE_SUFFIXES or not path.is_file() or "__pycache__" in path.parts:
            continue
        if path.name == "__main__.py" or path.name != "__init__.py" or defines_something(path):
            out.append(path.relative_to(package).as_posix())
    return out


def map_entries(text: str) -> dict[str, str]:
    """The map's entries under ``fmu_src/tribofmu/``: their head (``coupling/``, ``api.py, cli.py``)
    -> their whole text."""
    block = re.search(r"```\nfmu_src/tribofmu/\n(.*?)\n(?=\S)", text, re.S)
    assert block, "docs/layout.md: no code block starting with the line fmu_src/tribofmu/"
    entries: dict[str, str] = {}
    head = None
    for line in block.group(1).splitlines():
        if re.match(r"  \S", line):
            head = line.split("  ", 2)[1].strip() if line.count("  ") > 1 else line.strip()
            entries[head] = ""
        entries[head] += line + "\n"
    return entries


def named_modules(text: str, all_modules: list[str]) -> tuple[set[str], list[str]]:
    """(the modules the map names, the paths it writes that name no module)."""
    named, unknown = set(), []
    for head, body in map_entries(text).items():
        folders = [word[:-1] for word in re.findall(r"[\w]+/", head)]
        for written in WRITTEN.findall(body):
            if written in all_modules and ("/" in written or not folders):
                named.add(written)  # a whole path (coupling/embedded.py), or a top-level module
                continue
            for folder in folders:  # coupling/embedded.py in coupling's entry
                written = written.removeprefix(folder + "/")
            candidates = [m for folder in folders for m in all_modules
                          if m.startswith(folder + "/") and ("/" + m).endswith("/" + written)]
            if len(candidates) == 1:
                named.add(candidates[0])
            elif not candidates:
                unknown.append(f"{written} (in the entry {head!r})")
    return named, unknown


def test_layout_names_every_module_of_the_package():
    all_modules = modules()
    assert "api.py" in all_modules and "coupling/algorithms.py" in all_modules  # the walk sees the package
    named, _ = named_modules(LAYOUT.read_text(encoding="utf-8"), all_modules)
    missing = [m for m in all_modules if m not in named]
    assert not missing, ("docs/layout.md does not name these modules of fmu_src/tribofmu (add each, "
                         "with one line on its role, to its folder's entry): " + ", ".join(missing))


def test_layout_names_no_module_that_is_gone():
    _, unknown = named_modules(LAYOUT.read_text(encoding="utf-8"), modules())
    assert not unknown, "docs/layout.md names modules that fmu_src/tribofmu does not have: " + ", ".join(unknown)


def test_the_check_finds_a_missing_module_and_a_gone_one(tmp_path):
    """The rule itself: a module left out of its folder's entry is missing; one written under
    the wrong folder, or written twice ambiguously, is not named; a written one that is gone is
    reported."""
    for relative in ("api.py", "plots.py", "coupling/algorithms.py", "coupling/embedded.py", "physics/laws/dry.py",
                     "studies/reference/plots.py", "studies/sweep/plots.py", "studies/sweep/__init__.py",
                     "scene/__init__.py"):
        path = tmp_path / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("def f():\n    pass\n" if relative == "studies/sweep/__init__.py" else "")
    found = modules(tmp_path)
    assert found == ["api.py", "coupling/algorithms.py", "coupling/embedded.py", "physics/laws/dry.py",
                     "plots.py", "studies/reference/plots.py", "studies/sweep/__init__.py", "studies/sweep/plots.py"]
    doc = ("```\nfmu_src/tribofmu/\n"
           "  coupling/       algorithms.py (the registry)\n"
           "                  and contact.py (gone)\n"
           "  physics/        laws/dry.py, embedded.py (wrong folder)\n"
           "  studies/        plots.py (which one?), sweep/__init__.py\n"
           "  api.py          the front door\n"
           "tests/            unit/test_x.py\n```\n")
    named, unknown = named_modules(doc, found)
    assert named == {"api.py", "coupling/algorithms.py", "physics/laws/dry.py", "studies/sweep/__init__.py"}
    assert "plots.py" not in named  # studies/'s plots.py is not the top-level one
    assert unknown == ["contact.py (in the entry 'coupling/')", "embedded.py (in the entry 'physics/')"]
