"""The package says what its FMUs say: the licence and authors of pyproject.toml and LICENSE
are the ones every FMU's modelDescription.xml declares; no exact pin without its reason; no
empty extra; a changelog."""
import re
import tomllib

from scenes import ROOT


def project():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_the_licence_and_authors_are_the_fmus():
    from tribofmu.fmu.fmi import AUTHOR, LICENSE
    meta = project()
    assert meta["license"] == LICENSE == "MIT"
    assert meta["authors"] == [{"name": AUTHOR}]
    assert meta["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License") and f"Copyright (c) 2026 {AUTHOR}" in text
    assert meta["readme"] == "README.md" and meta["classifiers"]


def test_runtime_dependencies_are_ranges_and_no_extra_is_empty():
    meta = project()
    for requirement in meta["dependencies"]:
        assert "==" not in requirement, requirement
    pins = {name: reqs for name, reqs in meta["optional-dependencies"].items()}
    assert all(pins.values()), pins  # an empty extra installs nothing: there is none


def test_the_changelog_names_this_version():
    from tribofmu import __version__
    text = (ROOT / "CHANGELOG.md").read_text()
    assert re.search(rf"^## {re.escape(__version__)} ", text, re.M)
