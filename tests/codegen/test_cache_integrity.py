"""The compile cache trusts nothing on disk.

Every library has a SHA-256 checksum file, verified before the library is loaded: a
truncated, replaced or unverifiable entry is rebuilt atomically (never mapped: no SIGBUS,
no foreign code). Entries or cache directories that are foreign or writable by others are
refused; a cache that cannot be used falls back to a private one with one warning line.
The functions compiled here are tiny casadi Functions (a few ms each).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ca = pytest.importorskip("casadi")

from observer_cad.codegen import (CodegenError, compile_function, usable_cache_dir,  # noqa: E402
                                  verify_library)

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(shutil.which(os.environ.get("CC") or "cc") is None,
                              reason="no C compiler")
pytestmark = needs_cc
is_root = hasattr(os, "getuid") and os.getuid() == 0


def tiny(name="ocad_tiny", k=2.0):
    x = ca.SX.sym("x", 2)
    return ca.Function(name, [x], [k * x + 1], ["x"], ["y"])


def value(fn):
    return [float(v) for v in fn(ca.DM([1, 2])).full().ravel()]


def warnings_of(capsys):
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]


def test_entry_records_its_checksum_and_is_verified(tmp_path):
    c = compile_function(tiny(), cache=tmp_path)
    assert not c.cached
    s = c.path.with_name(c.path.name + ".sha256")
    digest, fname = s.read_text().split()
    assert fname == c.path.name and len(digest) == 64
    assert verify_library(c.path) is None
    assert (c.path.stat().st_mode & 0o022) == 0
    assert compile_function(tiny(), cache=tmp_path).cached


@pytest.mark.parametrize("fault", ["truncated", "garbage", "other_library", "no_checksum",
                                   "bad_checksum_file", "empty"])
def test_a_damaged_entry_is_rebuilt_not_loaded(tmp_path, capsys, fault):
    # build the entry in cache a, damage a copy in cache b (a path never loaded here)
    a, b = tmp_path / "a", tmp_path / "b"
    c = compile_function(tiny(), cache=a)
    b.mkdir()
    for f in a.iterdir():
        shutil.copy2(f, b / f.name)
    lib = b / c.path.name
    if fault == "truncated":
        lib.write_bytes(lib.read_bytes()[: lib.stat().st_size // 2])
    elif fault == "garbage":
        lib.write_bytes(b"\x7fELF" + b"\0" * 100)
    elif fault == "other_library":
        other = compile_function(tiny("ocad_tiny", k=3.0), cache=tmp_path / "c")
        lib.write_bytes(other.path.read_bytes())
    elif fault == "no_checksum":
        (b / (lib.name + ".sha256")).unlink()
    elif fault == "bad_checksum_file":
        (b / (lib.name + ".sha256")).write_bytes(b"\xff\xfe not hex")
    elif fault == "empty":
        lib.write_bytes(b"")
    assert verify_library(lib) is not None
    capsys.readouterr()
    c2 = compile_function(tiny(), cache=b)
    assert not c2.cached and c2.path == lib
    assert verify_library(lib) is None
    assert value(c2.function) == [3.0, 5.0]
    assert warnings_of(capsys) == []  # a broken entry is rebuilt quietly
    assert not list(b.glob(".tmp-*"))


TRUNCATED_SCRIPT = """
import sys
from observer_cad import load_model, design, build_observer
from observer_cad.codegen import CompiledSimulator
m = load_model(sys.argv[1])
d = design(m, observer="unknown-input", faults=["d"])
cs = CompiledSimulator(m, build_observer(m, d))
print(cs.cached, cs.translated)
"""


@pytest.mark.slow  # two fresh interpreters and a compile: ~4.5 s
def test_truncated_library_in_a_fresh_process_is_rebuilt_without_a_crash(tmp_path):
    """A truncated .so killed every later run with SIGBUS (exit 135)."""
    cache = tmp_path / "cache"
    env = dict(os.environ, OBSERVER_CAD_CACHE=str(cache), PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-c", TRUNCATED_SCRIPT, str(ROOT / "models" / "electric_drive.py")]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    libs = list(cache.glob("*.so"))
    assert len(libs) == 1
    libs[0].write_bytes(libs[0].read_bytes()[:4096])
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, (r.returncode, r.stderr)
    assert r.stdout.split() == ["False", "True"]  # rebuilt: translated, compiled again
    assert r.stderr == ""
    assert verify_library(libs[0]) is None


def test_group_writable_entry_is_refused_with_one_warning(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    c = compile_function(tiny(), cache=a)
    shutil.copytree(a, b)
    lib = b / c.path.name
    os.chmod(lib, 0o666)
    capsys.readouterr()
    c2 = compile_function(tiny(), cache=b)
    assert not c2.cached and (lib.stat().st_mode & 0o022) == 0
    w = warnings_of(capsys)
    assert len(w) == 1 and "writable by group or others" in w[0] and "rebuilt" in w[0], w


@pytest.mark.skipif(not is_root, reason="changing a file's owner needs root")
def test_foreign_entry_is_refused(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    c = compile_function(tiny(), cache=a)
    shutil.copytree(a, b)
    lib = b / c.path.name
    os.chown(lib, 65534, 65534)
    capsys.readouterr()
    c2 = compile_function(tiny(), cache=b)
    assert not c2.cached and lib.stat().st_uid == os.getuid()
    w = warnings_of(capsys)
    assert len(w) == 1 and "owned by another user" in w[0], w


@pytest.mark.parametrize("problem", ["world_writable", "foreign", "not_creatable", "a_file"])
def test_untrusted_or_unusable_cache_dir_falls_back_to_a_private_cache(tmp_path, capsys,
                                                                       problem):
    d = tmp_path / "shared"
    if problem == "world_writable":
        d.mkdir()
        os.chmod(d, 0o777)
    elif problem == "foreign":
        if not is_root:
            pytest.skip("changing a directory's owner needs root")
        d.mkdir()
        os.chown(d, 65534, 65534)
    elif problem == "not_creatable":
        (tmp_path / "file").write_text("x")
        d = tmp_path / "file" / "cache"
    elif problem == "a_file":
        d.write_text("not a directory")
    capsys.readouterr()
    used = usable_cache_dir(d)
    assert used != d
    assert (used.stat().st_mode & 0o077) == 0 and used.stat().st_uid == os.getuid()
    c = compile_function(tiny(f"ocad_fallback_{problem}"), cache=d)
    assert c.path.parent == used and value(c.function) == [3.0, 5.0]
    w = warnings_of(capsys)
    assert len(w) == 1 and str(d) in w[0] and "private cache" in w[0], w
    if d.is_dir():
        assert not list(d.glob("*.so"))


def test_entry_path_taken_by_a_directory_uses_the_private_cache(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    c = compile_function(tiny("ocad_dir_in_way"), cache=a)
    b.mkdir()
    (b / c.path.name).mkdir()  # something in the way of the atomic rename
    capsys.readouterr()
    c2 = compile_function(tiny("ocad_dir_in_way"), cache=b)
    assert c2.path.parent != b and value(c2.function) == [3.0, 5.0]
    w = warnings_of(capsys)
    assert len(w) == 1 and "cannot write" in w[0] and "private cache" in w[0], w


def test_fingerprint_record_pointing_at_a_damaged_library_is_not_loaded(tmp_path):
    x = ca.SX.sym("x", 2)
    build = lambda: ca.Function("ocad_fp", [x], [5 * x], ["x"], ["y"])  # noqa: E731
    c1 = compile_function(build, name="ocad_fp", identity=("fp-test", 5), cache=tmp_path / "a")
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    lib = tmp_path / "b" / c1.path.name
    lib.write_bytes(lib.read_bytes()[:100])
    c2 = compile_function(build, name="ocad_fp", identity=("fp-test", 5), cache=tmp_path / "b")
    assert c2.translated and not c2.cached  # the record was not trusted; rebuilt
    assert verify_library(lib) is None
    c3 = compile_function(build, name="ocad_fp", identity=("fp-test", 5), cache=tmp_path / "b")
    assert c3.cached and not c3.translated


def test_codegen_error_is_an_observer_cad_error():
    from observer_cad.errors import ObserverCadError
    assert issubclass(CodegenError, ObserverCadError)


def test_demo_module_with_an_unusable_cache_still_compiles(tmp_path):
    """An unusable cache made ``demo`` report no design certified; now it
    carries on in a private cache after one warning line."""
    (tmp_path / "file").write_text("x")
    code = textwrap.dedent("""
        import sys
        from observer_cad import load_model, design, build_observer
        from observer_cad.codegen import CompiledSimulator
        m = load_model(sys.argv[1])
        cs = CompiledSimulator(m, build_observer(m, design(m, observer="unknown-input", faults=["d"])))
        print("ok", cs.path.parent != sys.argv[2])
    """)
    env = dict(os.environ, OBSERVER_CAD_CACHE=str(tmp_path / "file" / "cache"),
               PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-c", code, str(ROOT / "models" / "electric_drive.py"),
                        str(tmp_path / "file" / "cache")], capture_output=True, text=True,
                       env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["ok", "True"]
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and "private cache" in lines[0], r.stderr


def test_a_changed_source_copy_is_not_what_the_workers_build(tmp_path):
    """The library's C is kept next to it and is what process workers rebuild from; a copy
    that is not the library's source (its key differs) is regenerated from the equations
    instead (an audit appended a comment to it: every process-backend ensemble then
    refused to run, and the entry never recovered)."""
    from observer_cad import build_observer, design, load_model
    from observer_cad.codegen import CompiledSimulator
    from observer_cad.codegen._compile import compiler, source_key

    m = load_model(ROOT / "models" / "electric_drive.py")
    o = build_observer(m, design(m, observer="unknown-input", faults=["d"]))
    first = CompiledSimulator(m, o, cache=tmp_path)
    good = first.source
    copy = first.path.with_suffix(".c")
    assert copy.read_text() == good
    copy.write_text(good + "\n/* changed */\n")
    again = CompiledSimulator(m, o, cache=tmp_path)
    assert again.cached and again.key == first.key
    assert again.source == good
    assert source_key(again.engine().spec.source, compiler(None), tuple(again.flags)) == again.key
