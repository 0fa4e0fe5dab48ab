"""Output files are written atomically (a temporary file, then a rename) and get the mode
any file the user writes gets (0o666 without the umask) — not mkstemp's 0o600 (an audit
found every CSV, JSON and figure readable by the owner only)."""
import os
import stat

from observer_cad.files import atomic_write_text, new_file_mode, staged_directory


def test_atomic_and_staged_files_follow_the_umask(tmp_path):
    from observer_cad.reporting._plots import _plt, save_figure

    old = os.umask(0o027)
    try:
        assert new_file_mode() == 0o640
        atomic_write_text(tmp_path / "a.txt", "x\n")
        fig = _plt().figure()
        save_figure(fig, tmp_path / "f.png")
        with staged_directory(tmp_path / "out") as stage:
            atomic_write_text(stage / "b.txt", "y\n")
        for p in (tmp_path / "a.txt", tmp_path / "f.png", tmp_path / "out" / "b.txt"):
            assert stat.S_IMODE(p.stat().st_mode) == 0o640, p
        assert sorted(x.name for x in (tmp_path / "out").iterdir()) == ["b.txt"]
    finally:
        os.umask(old)
