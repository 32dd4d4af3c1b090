"""Issue 36's structure target that a change can pass unnoticed: no module of the package over
450 lines (a module that long holds more than one idea; split it where its ideas part)."""
from pathlib import Path

import tribofmu

MAX_MODULE_LINES = 450
PACKAGE = Path(tribofmu.__file__).resolve().parent


def test_no_module_of_the_package_is_over_its_line_limit():
    too_long = {path.relative_to(PACKAGE).as_posix(): n for path in PACKAGE.rglob("*.py")
                if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not too_long, too_long
