"""Every file the tool reads is checked before a byte is read (cml_edge.io.reading): special
files, symbolic-link loops, folders and files beyond their kind's bound are refused in one
line, and an .npz whose members declare more than the bound is refused before any loads."""

from __future__ import annotations

import io
import os
import zipfile

import numpy as np
import pytest
from numpy.lib import format as fmt

from cml_edge.errors import InputError
from cml_edge.io.files import writable_file, writable_folder
from cml_edge.io.reading import npz_members, read_bytes, read_text, regular_file


def test_special_files_and_loops_are_refused_without_reading_them(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)  # opening it would block until a writer came
    with pytest.raises(InputError, match="map file '.*fifo' is a FIFO, not a regular file"):
        read_text(fifo, "map file", 100)
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    with pytest.raises(InputError, match="is a loop of symbolic links"):
        regular_file(tmp_path / "a", "model file", 100)
    with pytest.raises(InputError, match="is a character device"):
        regular_file("/dev/zero", "model file", 100)
    with pytest.raises(InputError, match="is a folder, not a file"):
        regular_file(tmp_path, "model file", 100)
    with pytest.raises(InputError, match="does not exist"):
        regular_file(tmp_path / "none", "model file", 100)


def test_a_file_beyond_its_bound_is_refused(tmp_path):
    big = tmp_path / "big"
    big.write_bytes(b"x" * 101)
    with pytest.raises(InputError, match="is 101 bytes, more than the 100 a scenario file"):
        read_bytes(big, "scenario file", 100)
    assert read_bytes(big, "scenario file", 101) == b"x" * 101
    (tmp_path / "latin").write_bytes(b"\xff")
    with pytest.raises(InputError, match="is not ascii text"):
        read_text(tmp_path / "latin", "map file", 10, "ascii")


def _npz_declaring(shape, dtype="<f8") -> bytes:
    """An .npz whose one member declares ``shape`` and holds no data."""
    member = io.BytesIO()
    fmt.write_array_header_2_0(member, {"descr": dtype, "fortran_order": False,
                                        "shape": shape})
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("W.npy", member.getvalue())
    return out.getvalue()


def test_an_npz_declaring_terabytes_is_refused_before_loading(tmp_path):
    path = tmp_path / "huge.npz"
    path.write_bytes(_npz_declaring((1000, 1000, 1000, 1000)))  # 8 TB of float64
    with pytest.raises(InputError, match=r"declares arrays of more than 1,000,000 bytes "
                                         r"\(member 'W.npy'\)"):
        npz_members(path, "model file", 10**6)
    good = tmp_path / "ok.npz"
    np.savez(good, W=np.arange(3.0))
    assert np.array_equal(npz_members(good, "model file", 10**6)["W"], np.arange(3.0))
    (tmp_path / "junk.npz").write_bytes(b"PK not a zip")
    with pytest.raises(InputError, match="is not a readable .npz model file"):
        npz_members(tmp_path / "junk.npz", "model file", 10**6)


def test_a_run_file_that_is_no_object_is_refused_in_one_line(tmp_path):
    from cml_edge.engine.runs import open_run

    for text in ("[1, 2]", '"run"', "{", '{"format": "cml-edge-run", "settings": []}'):
        (tmp_path / "run.json").write_text(text)
        with pytest.raises(InputError, match="is not a cml-edge run file") as err:
            open_run(tmp_path, {"a": 1}, [])
        assert "\n" not in str(err.value)


def test_a_forged_task_file_with_nan_results_is_computed_again(tmp_path):
    import json

    from cml_edge.engine.runs import checksum, plain
    from cml_edge.engine.sweep import TASK_FORMAT, Task, load_done, task_path

    task = Task("k", "math:sqrt", {"x": 1})
    doc = {"format": TASK_FORMAT, "fn": task.fn, "params": plain(task.params),
           "result": {"value": 1.0}}
    doc["checksum"] = checksum(doc, None)
    path = task_path(tmp_path, "k")
    path.parent.mkdir()
    path.write_text(json.dumps(doc))
    assert load_done(tmp_path, task)["result"] == {"value": 1.0}
    doc["result"] = {"value": float("nan")}
    doc["checksum"] = checksum(doc, None)  # a checksum recomputed by the forger
    path.write_text(json.dumps(doc))  # NaN, which strict JSON has no word for
    assert load_done(tmp_path, task) is None
    doc["result"] = [1.0]
    doc["checksum"] = checksum(doc, None)
    path.write_text(json.dumps(doc))
    assert load_done(tmp_path, task) is None
    path.unlink()
    os.mkfifo(path)
    with pytest.raises(InputError, match="task file .* is a FIFO"):
        load_done(tmp_path, task)


@pytest.mark.parametrize("check", [writable_file, writable_folder])
def test_an_output_under_a_symlink_loop_or_a_dangling_link_is_refused(check, tmp_path):
    """``Path.exists`` is False for both, so a probe that trusted it passed them and the
    write failed after the work."""
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
    with pytest.raises(InputError, match="symbolic links"):
        check(tmp_path / "loop" / "out")
    if check is writable_folder:  # a file is written over the link itself
        with pytest.raises(InputError, match="symbolic links"):
            check(tmp_path / "loop")
    with pytest.raises(InputError, match="nowhere', which does not exist"):
        check(tmp_path / "gone" / "out")
    assert check(tmp_path / "new" / "out") == tmp_path / "new" / "out"
