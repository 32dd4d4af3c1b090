"""Every module the FMUs ship besides their FMI adapter imports with the standard library
alone (no numpy, no fmpy): an FMU runs in whatever Python its host has."""
import subprocess
import sys

from tribofmu import build


def test_every_shipped_module_imports_without_site_packages(tmp_path):
    private = "_tribofmu_ship_check"
    package = build._stage_package(tmp_path, private)
    modules = sorted(
        ".".join(p.relative_to(tmp_path).with_suffix("").parts).removesuffix(".__init__")
        for p in package.rglob("*.py")
        # (the fmu package is the FMI adapter: it needs pythonfmu, which every host running a
        # pythonfmu FMU has; what it adapts must need nothing more)
        if "fmu" not in p.relative_to(package).parts[:1])
    assert any(m.endswith(".coupling.pair") for m in modules)
    code = ("import importlib, sys\nsys.path.insert(0, sys.argv[1])\n"
            "for m in sys.argv[2:]:\n    importlib.import_module(m)\n")
    # -S: no site-packages (numpy, fmpy, pythonfmu are not importable); -I: no user paths
    proc = subprocess.run([sys.executable, "-I", "-S", "-c", code, str(tmp_path), *modules],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_shipped_packages_are_whole_packages():
    # nothing is shipped from a hand-kept list of single files
    assert all((build.PACKAGE / rel).is_dir() or rel == "__init__.py" for rel in build.SHIPPED)
