"""Issue 36's structure target "one advance() touches at most 25 functions", measured.

    python benchmarks/bench_advance.py [--scenes fig6_boundary,fig2_dry] [--radau]

Runs each scene's default call in this process (``tribofmu.api.simulate``, one check worker, so
every run of its check is in this process) with a profile hook (``sys.setprofile``) switched on
for each outermost ``EmbeddedCoupling.advance`` call: one call is one step tried, accepted or
not. Per call it collects the distinct Python functions the master runs, counted by file and
qualified name, and prints the median, the 90th percentile and the maximum over all calls, with
the files they lie in. Functions run inside an FMU (its own Python, which pythonfmu runs in this
interpreter from the folder the FMU was unpacked to, and whatever that calls) are counted apart,
as are fmpy's own functions (the FMI crossing; the master calls the hot FMI functions through
its own ctypes signatures, so a step reaches few of them). C functions are not counted (the profile reports them, but they
are no code of ours).

``--radau`` prints the same count for one ``scipy.integrate.Radau.step`` on a stiff linear
problem, the issue's yardstick (its functions in scipy and numpy's Python files).

Not collected by pytest (no test_ prefix); no timing.
"""
from __future__ import annotations

import argparse
import re
import datetime
import statistics
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class AdvanceProfile:
    """Distinct functions per outermost advance() call, split by where they run."""

    def __init__(self) -> None:
        self.master: list[set[tuple[str, str]]] = []
        self.fmu: list[set[tuple[str, str]]] = []
        self.crossing: list[set[tuple[str, str]]] = []
        self._fmu_depth = 0

    def _hook(self, frame, event, arg) -> None:
        if event not in ("call", "return"):
            return
        code = frame.f_code
        # an FMU's own Python runs from where it was unpacked (its resources/); the master may
        # reach it through fmpy or through its own ctypes calls of the FMU's library
        inside = "/fmpy/" in code.co_filename or "/resources/" in code.co_filename
        if event == "return":
            if inside:
                self._fmu_depth -= 1
            return
        key = (code.co_filename, getattr(code, "co_qualname", code.co_name))
        if "/fmpy/" in code.co_filename:
            self.crossing[-1].add(key)
        elif inside or self._fmu_depth > 0:
            self.fmu[-1].add(key)
        else:
            self.master[-1].add(key)
        if inside:
            self._fmu_depth += 1

    def wrap(self, cls) -> None:
        original = cls.advance
        depth = [0]
        profile = self

        def advance(self_, *args, **kwargs):
            if depth[0]:
                return original(self_, *args, **kwargs)
            profile.master.append(set())
            profile.fmu.append(set())
            profile.crossing.append(set())
            profile._fmu_depth = 0
            depth[0] += 1
            sys.setprofile(profile._hook)
            try:
                return original(self_, *args, **kwargs)
            finally:
                sys.setprofile(None)
                depth[0] -= 1

        cls.advance = advance


# Not functions of their own: comprehensions, generator expressions and lambdas are lines of
# the function they sit in.
INLINE = re.compile(r"<(genexpr|listcomp|dictcomp|setcomp|lambda)>")


def own(calls: list[set[tuple[str, str]]], where: str) -> list[set[tuple[str, str]]]:
    """The functions of files whose path contains where, without inline ones. (An FMU's Python
    runs from the folder fmpy unpacked it to, under its resources/.)"""
    return [{(f, q) for f, q in c if where in f and not INLINE.search(q)} for c in calls]


def summary(label: str, calls: list[set[tuple[str, str]]]) -> str:
    counts = sorted(len(c) for c in calls)
    files = sorted(len({f for f, _ in c}) for c in calls)
    if not counts:
        return f"  {label:<24} no calls"
    p90 = counts[min(len(counts) - 1, int(0.9 * len(counts)))]
    return (f"  {label:<24} functions median {statistics.median(counts):.0f}, p90 {p90}, max {counts[-1]}; "
            f"files median {statistics.median(files):.0f}, max {files[-1]}")


def common_functions(calls: list[set[tuple[str, str]]], top: int = 40) -> list[str]:
    tally = Counter(k for c in calls for k in c)
    root = str(ROOT / "fmu_src") + "/"
    return [f"    {n / len(calls):5.0%}  {f.replace(root, '')}:{q}" for (f, q), n in tally.most_common(top)]


def scene(name: str, verbose: bool) -> None:
    from tribofmu import api
    from tribofmu.coupling.embedded import EmbeddedCoupling

    profile = AdvanceProfile()
    original = EmbeddedCoupling.advance
    profile.wrap(EmbeddedCoupling)
    try:
        result = api.simulate(ROOT / "scenarios" / f"{name}.toml", check_workers=1)
    finally:
        EmbeddedCoupling.advance = original
    runs = len(result.stats.get("check", {}).get("runs", [])) or 1
    print(f"{name}: {len(profile.master)} advance() calls over {runs} run(s)")
    print(summary("master: tribofmu's own", own(profile.master, "/tribofmu/")))
    print(summary("master: all Python", profile.master))
    print(summary("inside the FMUs: ours", own(profile.fmu, "/resources/")))
    print(summary("fmpy (FMI crossing)", profile.crossing))
    if verbose:
        print("  the master's functions, by the share of calls that touch them:")
        print("\n".join(common_functions(own(profile.master, "/tribofmu/"), top=200)))


def radau() -> None:
    import numpy as np
    from scipy.integrate import Radau

    calls: list[set[tuple[str, str]]] = []

    def hook(frame, event, arg):
        if event == "call":
            code = frame.f_code
            calls[-1].add((code.co_filename, getattr(code, "co_qualname", code.co_name)))

    matrix = np.array([[0.0, 1.0], [-2000.0, -50.0]])
    solver = Radau(lambda t, y: matrix @ y, 0.0, np.array([1.0, 0.0]), 10.0, rtol=1e-4, atol=1e-8)
    for _ in range(200):
        if solver.status != "running":
            break
        calls.append(set())
        sys.setprofile(hook)
        try:
            solver.step()
        finally:
            sys.setprofile(None)
    print(f"scipy Radau.step: {len(calls)} calls")
    print(summary("scipy's own", own(calls, "/scipy/")))
    print(summary("all Python (numpy too)", calls))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="fig6_boundary,fig2_dry")
    parser.add_argument("--radau", action="store_true")
    parser.add_argument("--verbose", action="store_true", help="list the master's functions")
    args = parser.parse_args(argv)
    print(f"# bench_advance, {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC")
    for name in args.scenes.split(","):
        scene(name.strip(), args.verbose)
    if args.radau:
        radau()
    return 0


if __name__ == "__main__":
    sys.exit(main())
