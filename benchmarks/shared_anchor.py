"""Issue 36's Fig. 6 anchor as a user runs it, a whole process: LSODA at rtol 1e-4 on the
hand-written scipy right-hand side of ``../shared/anchors/reference.py`` (beside the project's
checkout). For whole-command timings against ``tribofmu simulate fig6_boundary``:

    farm-bench -n 5 --vs "python benchmarks/shared_anchor.py" -- sh -c 'rm -rf /tmp/f6 && exec python -m tribofmu simulate fig6_boundary --out /tmp/f6 --no-plots -q'
"""
import sys
from pathlib import Path

ANCHORS = Path(__file__).resolve().parents[2] / "shared" / "anchors"
if not (ANCHORS / "reference.py").is_file():
    sys.exit(f"shared_anchor: no {ANCHORS / 'reference.py'}")
sys.path.insert(0, str(ANCHORS))
import reference  # noqa: E402

reference.boundary(method="LSODA", rtol=1e-4, atol=(1e-12, 1e-10, 1e-6))
