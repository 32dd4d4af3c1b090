"""Nothing runs because of its name; a sweep never mixes two physics: an FMU is trusted for
its content, not for the file name or folder it is found under.

- the per-user cache: a planted, damaged or linked FMU is rebuilt (that one alone), as is a
  missing one; leftovers of killed builds are removed;
- Dask workers: the FMUs they receive are written into their private folder and checked by
  content; a planted ``$TMPDIR/tribofmu-fmus-<digest>`` is never used;
- sweep.json records the FMUs' source, and extending a sweep computed with other FMUs is
  refused (or, with recompute, every point runs again).
"""
from __future__ import annotations

import hashlib
import json
import stat
import tempfile
from pathlib import Path

import pytest

from cli_run import main
from scenes import FIG2

SHORT = {"time.periods": 1, "time.window": [0, 1]}
NAMES = ("Drive", "BlockSpring", "Friction")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBOFMU_CACHE", str(tmp_path / "cache"))
    from tribofmu.fmu_cache import find_fmus
    folder = find_fmus(NAMES)
    return folder


def stamps(folder: Path) -> dict[str, tuple[int, int]]:
    return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in folder.glob("*.fmu")}


def test_the_cache_is_private_and_records_what_it_built(cache):
    from tribofmu.build import cache_root
    from tribofmu.fmu_cache import sha256_file
    assert stat.S_IMODE(cache_root().stat().st_mode) == 0o700
    manifest = json.loads((cache / "manifest.json").read_text())
    assert {n: sha256_file(cache / f"{n}.fmu") for n in NAMES} == manifest


@pytest.mark.parametrize("plant", ["other-bytes", "symlink", "missing"])
def test_a_planted_or_missing_cached_fmu_is_rebuilt_alone(cache, tmp_path, plant):
    from tribofmu.fmu_cache import find_fmus, sha256_file
    target = cache / "Drive.fmu"
    before = stamps(cache)
    if plant == "other-bytes":  # a valid FMU of the wrong kind, under the right name
        target.write_bytes((cache / "Friction.fmu").read_bytes())
    elif plant == "symlink":
        elsewhere = tmp_path / "elsewhere.fmu"
        elsewhere.write_bytes(target.read_bytes())
        target.unlink()
        target.symlink_to(elsewhere)
    else:
        target.unlink()
    assert find_fmus(NAMES) == cache
    after = stamps(cache)
    assert not target.is_symlink()
    assert sha256_file(target) == json.loads((cache / "manifest.json").read_text())["Drive"]
    assert {k: v for k, v in after.items() if k != "Drive.fmu"} == {k: v for k, v in before.items()
                                                                     if k != "Drive.fmu"}


def test_leftovers_of_killed_builds_are_removed(cache, tmp_path, monkeypatch):
    from tribofmu.fmu_cache import find_fmus
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(tempfile, "tempdir", None)
    partial = cache / ".Drive.fmu.partial-999999999"
    staging = tmp_path / "tribofmu_build_999999999_abc"
    partial.write_bytes(b"half")
    staging.mkdir()
    (cache / "Friction.fmu").unlink()  # a build is needed
    find_fmus(NAMES)
    assert not partial.exists() and not staging.exists()


def test_workers_use_only_what_they_received(tmp_path, monkeypatch, fmu_dir):
    """A folder planted under the name older workers computed is ignored; a copy changed
    after unpacking is written again before use."""
    import tribofmu.master.fmu_files as fmu_files
    from tribofmu.studies.sweep.worker import pack_fmus, unpack_fmus
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(fmu_files, "_extract_root", None)
    bundle = pack_fmus(fmu_dir, ["Friction"])
    digest = hashlib.sha1()
    for name in sorted(bundle):
        digest.update(name.encode() + b"\0" + hashlib.sha1(bundle[name]).digest())
    planted = tmp_path / f"tribofmu-fmus-{digest.hexdigest()[:16]}"
    planted.mkdir()
    (planted / "Friction.fmu").write_bytes(b"planted")
    folder = Path(unpack_fmus(bundle))
    assert folder.parent != tmp_path and planted not in folder.parents and folder != planted
    assert stat.S_IMODE(folder.parent.stat().st_mode) == 0o700
    assert (folder / "Friction.fmu").read_bytes() == bundle["Friction.fmu"]
    (folder / "Friction.fmu").write_bytes(b"changed")
    assert Path(unpack_fmus(bundle)) == folder
    assert (folder / "Friction.fmu").read_bytes() == bundle["Friction.fmu"]
    fmu_files.remove_orphan_extractions(tmp_path)  # an all-digit name is no pid: no OverflowError
    digits = tmp_path / "tribofmu-fmus-1234567890123456"
    digits.mkdir()
    fmu_files.remove_orphan_extractions(tmp_path)
    assert digits.exists()


def test_a_sweep_records_its_fmus_and_refuses_to_mix_physics(tmp_path, fmu_dir):
    from tribofmu.build import private_package_name
    from tribofmu.errors import SweepError
    from tribofmu.studies.sweep import sweep
    out = tmp_path / "sweep"
    kw = dict(workers=0, overrides=SHORT, fmu_dir=fmu_dir, progress=False, plots=False)
    sweep(FIG2, {"drive.omega": [30]}, out, **kw)
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["fmu_source"] == private_package_name() and meta["tribofmu"]
    # the stored rows came from FMUs of another source (as after a change of the code)
    meta["fmu_source"], meta["tribofmu"] = "_tribofmu_fmu_0_0_9_0123456789ab", "0.0.9"
    (out / "sweep.json").write_text(json.dumps(meta))
    with pytest.raises(SweepError, match=r"other FMUs .*0123456789ab.*now .*--recompute") as info:
        sweep(FIG2, {"drive.omega": [30, 50]}, out, **kw)
    assert private_package_name() in str(info.value) and "\n" not in str(info.value)
    rows = sweep(FIG2, {"drive.omega": [30, 50]}, out, recompute=True, **kw)
    assert rows.computed == 2 and rows.skipped == 0
    assert json.loads((out / "sweep.json").read_text())["fmu_source"] == private_package_name()
    assert sweep(FIG2, {"drive.omega": [30, 50]}, out, **kw).computed == 0  # same FMUs: extends


def test_cli_names_both_sources_in_one_line_exit_2(tmp_path, fmu_dir, capsys):
    out = tmp_path / "sweep"
    argv = ["sweep", FIG2, "--grid", "drive.omega=30", "--workers", "0", "--out", out,
            "--fmu-dir", fmu_dir, "-q", "--no-plots", "--set", "time.periods=1", "--set", "time.window=[0,1]"]
    assert main(*argv, capsys=capsys).returncode == 0
    meta = json.loads((out / "sweep.json").read_text())
    meta["fmu_source"] = "_tribofmu_fmu_0_0_9_0123456789ab"
    (out / "sweep.json").write_text(json.dumps(meta))
    refused = main(*argv, capsys=capsys)
    err = refused.stderr.strip()
    assert refused.returncode == 2 and len(err.splitlines()) == 1 and "0123456789ab" in err and "--recompute" in err, err
    assert main(*argv, "--recompute", capsys=capsys).returncode == 0


