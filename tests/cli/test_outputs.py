"""Output paths: every file and folder a command writes is checked before any work (exit 2,
one line, nothing written, in seconds), and a write that fails (a full disk) ends with one
line, exit 1, and no half file."""

import errno
import os

import pytest

from cml_edge.errors import RunError
from cml_edge.io.files import atomic_write, atomic_write_text, writable_file, writable_folder

# /proc takes no new files; /sys refuses them (permission denied, also as root)
UNWRITABLE = ["/proc/cml-edge-x", "/sys/cml-edge-x"]


def commands(bad):
    """(flag named in the error, argv) of every output path of every command."""
    return [
        ("--out", ["train", "--out", f"{bad}/m.npz"]),
        ("--out", ["emulate", "--seeds", "1", "--out", f"{bad}/r.json"]),
        ("--chips-out", ["emulate", "--backend", "crossbar", "--chips", "2",
                         "--chips-out", bad]),
        ("--plot", ["navigate", "missing.npz", "--start", "0", "0", "--goal", "1", "1",
                    "--plot", f"{bad}/p.png"]),
        ("--out", ["scenario", "paper", "--out", bad]),
        ("--out", ["breakpoint", "--knob", "read_noise", "--scenario", "paper",
                   "--backend", "crossbar", "--out", bad]),
        ("--out", ["sweep", "convergence", "--out", bad]),
        ("--out", ["report", "--quick", "--out", bad]),
        ("--out", ["robot", "train", "--out", f"{bad}/m.npz"]),
        ("--plot", ["robot", "navigate", "missing.npz", "--plot", f"{bad}/p.png"]),
        ("--out", ["export", "missing.npz", "--format", "lava", "--out", bad]),
        ("--out", ["device", "characterize", "--out", f"{bad}/c.json"]),
        ("--plot", ["device", "characterize", "--plot", f"{bad}/c.png"]),
        ("--results", ["dqn", "train", "--results", f"{bad}/r.json", "--models", "m"]),
        ("--models", ["dqn", "train", "--results", "r.json", "--models", bad]),
    ]


@pytest.mark.parametrize("bad", UNWRITABLE)
@pytest.mark.parametrize("case", range(len(commands("x"))))
def test_an_unwritable_output_is_refused_before_any_work(bad, case, cli, tmp_path,
                                                         monkeypatch):
    flag, argv = commands(bad)[case]
    monkeypatch.chdir(tmp_path)
    code, out, err = cli(*argv)
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("cml-edge: error: ") and flag in err, err
    assert "Traceback" not in err and out == ""
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag", ["--out", "--render"])
def test_a_report_folder_holding_other_files_is_refused(flag, cli, tmp_path):
    """The finished report replaces its folder whole: a folder of other files (beside a
    report's own) is refused before any work and left as it was."""
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "report.json").write_text('{"schema_version": 2}')
    (folder / "notes.txt").write_text("keep me")
    code, out, err = cli("report", "--quick", flag, folder)
    assert code == 2 and err.count("\n") == 1 and "holds other files (notes.txt)" in err, err
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt", "report.json"]


def test_the_report_checks_the_folder_it_is_renamed_in(tmp_path):
    with pytest.raises(Exception, match="cannot be written"):
        writable_folder("/sys/x/report")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(Exception, match="cannot be written"):
            writable_folder(ro / "sub")
        with pytest.raises(Exception, match="cannot be written"):
            writable_file(ro / "f.json")
    finally:
        ro.chmod(0o755)


def test_the_check_leaves_nothing_behind(tmp_path):
    writable_folder(tmp_path / "a" / "b")
    writable_file(tmp_path / "c.json")
    assert list(tmp_path.iterdir()) == []


def _full_disk(*_):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_leaves_no_half_file(tmp_path, monkeypatch):
    target = tmp_path / "r.json"
    atomic_write_text(target, "old")
    monkeypatch.setattr("cml_edge.io.files.os.fsync", _full_disk)
    with pytest.raises(RunError, match="no space left on device"):
        atomic_write_text(target, "new")
    with pytest.raises(RunError, match="no space left"):
        atomic_write(tmp_path / "n.json", lambda f: f.write(b"x"))
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_a_full_disk_ends_a_command_with_one_line(tmp_path, monkeypatch, cli):
    monkeypatch.setattr("cml_edge.io.files.os.fsync", _full_disk)
    code, out, err = cli("train", "--arena", "10", "--walks", "2", "--steps", "20",
                         "--out", tmp_path / "m.npz")
    lines = [line for line in err.splitlines() if "compiling" not in line]  # a cold cache
    assert code == 1 and len(lines) == 1 and "no space left on device" in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_while_writing_the_report(tmp_path, monkeypatch):
    from cml_edge.report.build import write_report

    monkeypatch.setattr("cml_edge.report.build.os.replace", _full_disk)
    monkeypatch.setattr("cml_edge.report.render.render_figures", lambda r, f: {})
    monkeypatch.setattr("cml_edge.report.render.render_markdown", lambda r, f, o=None: "")
    monkeypatch.setattr("cml_edge.report.render.render_html", lambda r, d, f, o=None: "")
    with pytest.raises(RunError, match="nothing was written"):
        write_report({"a": 1}, tmp_path / "rep")
    assert list(tmp_path.iterdir()) == []
