"""A newcomer's walk through the README: a fresh virtual environment, a plain (not editable)
``pip install`` of this checkout, then every ``tribofmu`` command of the README's ``bash``
blocks and then of the docs pages it links (``docs/*.md``, in the README's order), in order,
from a folder outside the checkout, with an empty ``HOME``.

The venv sees the site-packages of the interpreter running the tests (numpy, fmpy,
matplotlib... are not downloaded again): the system's, and when that interpreter is itself a
virtual environment's (a contributor's ``pip install -e '.[test]'`` into a venv), that venv's
too. The package is installed with ``--no-deps`` from a copy of the checkout (no build files
left in the checkout); pip's isolated build takes setuptools from its cache or the
package index, the only network the walk may use. Select
it with ``pytest -m newcomer``; it takes one to three minutes.
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from scenes import ROOT

pytestmark = [pytest.mark.integration, pytest.mark.newcomer]
SKIP = ("bash .ci/run",)  # the test command itself
# The native-host section's set-up of a target machine (another Python for the FMU to load):
# checked by tests/native, not by a walk through this install.
TARGET_MACHINE = ("export TRIBOFMU_LIBPYTHON=", "python3 -m pip install pythonfmu")
# Another tool's command line on an archive the walk exported: run by tests/external/test_omsimulator.py
OTHER_TOOLS = ("OMSimulator ",)


def walked_pages() -> list:
    """The README, then each docs page it links, in the order of its first link."""
    readme = (ROOT / "README.md").read_text()
    pages = dict.fromkeys(re.findall(r"\]\((docs/[\w.-]+\.md)\)", readme))
    return [ROOT / "README.md", *(ROOT / page for page in pages)]


def readme_commands() -> list[str]:
    """Every tribofmu command in the bash blocks of the README and the docs pages it links,
    in order (``a && b`` split)."""
    text = "\n".join(page.read_text() for page in walked_pages())
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            if not line or line in SKIP or line.startswith(TARGET_MACHINE + OTHER_TOOLS):
                continue
            for part in line.split(" && "):
                part = part.strip()
                if part.startswith("tribofmu "):
                    out.append(part)
                else:
                    assert part in ("python -m pip install .",), f"README command the walk does not know: {part}"
    return out


def see_the_running_venv(python) -> None:
    """When the tests run in a virtual environment, its site-packages (pythonfmu, fmpy, pip...)
    are not the system's that a new venv sees: add them to the new venv's path, after its own
    site-packages (so the package installed there wins), with their own .pth files processed."""
    if sys.prefix == sys.base_prefix:
        return
    ours = dict.fromkeys(sysconfig.get_path(key) for key in ("purelib", "platlib"))
    target = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                            capture_output=True, text=True, check=True).stdout.strip()
    lines = "".join(f"import site; site.addsitedir({path!r})\n" for path in ours)
    (Path(target) / "_the_tests_venv.pth").write_text(lines)


def test_the_readme_names_the_plain_install_and_the_scenes_by_name():
    text = (ROOT / "README.md").read_text()
    assert "python -m pip install . && tribofmu simulate fig2_dry" in text and "bash .ci/run" in text
    assert [p.name for p in walked_pages()][:1] == ["README.md"] and len(walked_pages()) >= 6
    commands = readme_commands()
    assert "tribofmu simulate fig2_dry" in commands and "tribofmu figures" in commands
    assert "tribofmu export-ssp fig2_dry --pair --out fig2_dry.ssp" in commands


def test_a_newcomer_walks_the_readme_in_a_fresh_venv(tmp_path):
    source = tmp_path / "checkout"
    shutil.copytree(ROOT, source, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", "out", "build", "*.egg-info", "__pycache__", ".pytest_cache", ".hypothesis", "docs"))
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=False, symlinks=True).create(env_dir)
    python = env_dir / "bin" / "python"
    see_the_running_venv(python)
    # a fresh account: an empty HOME (no ~/.cache), no XDG variables, no TRIBOFMU_CACHE
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME", "TRIBOFMU_CACHE") and not k.startswith("XDG_")}
    env.update(PATH=f"{env_dir / 'bin'}{os.pathsep}{env['PATH']}", HOME=str(home),
               PYTHONDONTWRITEBYTECODE="1", PIP_DISABLE_PIP_VERSION_CHECK="1")
    # the tests' interpreter's pip, run by the venv's python, installs into the venv (no deps);
    # --ignore-installed: leave the system's own tribofmu (a developer's editable one) alone
    install = subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--ignore-installed",
                              str(source)],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stderr
    shutil.rmtree(source)  # what runs is the installed package, not the copy it came from
    work = tmp_path / "newcomer"
    work.mkdir()
    where = subprocess.run([str(python), "-c", "import tribofmu, sys; print(tribofmu.__file__)"],
                           cwd=work, env=env, capture_output=True, text=True)
    assert where.returncode == 0 and where.stdout.strip().startswith(str(env_dir)), where.stdout + where.stderr
    tribofmu = env_dir / "bin" / "tribofmu"
    assert tribofmu.is_file()
    for command in readme_commands():
        argv = [str(tribofmu), *command.split()[1:]]
        proc = subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, f"{command}: exit {proc.returncode}\n{proc.stderr[-2000:]}"
        assert "Traceback" not in proc.stderr and "Warning" not in proc.stderr, f"{command}:\n{proc.stderr}"
    assert (work / "out" / "fig2_dry" / "result.csv").is_file()
    assert (work / "out" / "fig2_dry" / "time.png").is_file()
    from tribofmu.figures import PAPER_FIGURES, output_names
    assert sorted(p.name for p in (work / "out" / "figures").glob("*.png")) == sorted(output_names(PAPER_FIGURES))
    assert {"fig2.png", "fig6.png", "friction_fig2_dry.png"} <= set(output_names(PAPER_FIGURES))
    assert (work / "out" / "boundary_heating" / "friction.png").is_file()
    assert (work / "fig2_dry.ssp").is_file()  # the archive the README's OMSimulator line runs
    # the README's Python blocks, in the same folder (the tour's save calls, fmpy on that archive)
    for block in re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S):
        proc = subprocess.run([str(python), "-c", block], cwd=work, env=env, capture_output=True, text=True,
                              timeout=900)
        assert proc.returncode == 0, f"{block}\n{proc.stderr[-2000:]}"
    assert sorted(p.name for p in (work / "out" / "omega80").iterdir()) == [
        "columns.json", "friction.png", "phase.png", "result.csv", "stats.json", "time.png"]
    assert any((home / ".cache" / "tribofmu" / "fmus").glob("*/Friction.fmu"))  # the default cache, made
