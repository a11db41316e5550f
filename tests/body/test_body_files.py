"""The bounded reader every file reader uses (robot files, policy files, a results folder's files).

A FIFO, a folder, a device or (when asked) a symbolic link in a file's place is refused at once,
never waited on; a file over the bound is refused before it is read, or when it grows while read;
text must be UTF-8. Each caller's own one-line messages are tested with the caller.
"""

from __future__ import annotations

import os
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.body import files
from revolve_env.body.files import (
    FileTooLargeError,
    NotARegularFileError,
    read_bounded,
    read_text,
)

needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")


def _one_line(error: BaseException, path: Path) -> str:
    text = str(error)
    assert "\n" not in text and str(path) in text
    return text


@pytest.fixture
def fifo(tmp_path: Path) -> Iterator[Path]:
    """A FIFO with no writer. Were it opened to be read, the open would wait for one: a writer
    comes after a minute, so that a regression fails (on its assertion) instead of hanging."""
    path = tmp_path / "pipe"
    os.mkfifo(path)
    rescue = threading.Timer(60, lambda: os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK)))
    rescue.start()
    yield path
    rescue.cancel()


@needs_fifo
@pytest.mark.parametrize("follow_links", [True, False])
@pytest.mark.parametrize("reader", [read_bounded, read_text])
def test_a_fifo_is_refused_not_waited_on(fifo: Path, follow_links: bool,
                                          reader: Callable[..., object]) -> None:
    with pytest.raises(NotARegularFileError) as info:
        reader(fifo, 100, follow_links=follow_links)
    assert info.value.kind == "a FIFO"
    assert _one_line(info.value, fifo).endswith("is a FIFO, not a regular file")
    assert isinstance(info.value, OSError) and info.value.path == str(fifo)


@needs_fifo
def test_a_symbolic_link_to_a_fifo_is_the_fifo_or_refused_as_a_link(fifo: Path) -> None:
    link = fifo.with_name("link")
    link.symlink_to(fifo)
    with pytest.raises(NotARegularFileError) as info:
        read_bounded(link, 100)  # followed: the FIFO it leads to is refused
    assert info.value.kind == "a FIFO"
    with pytest.raises(NotARegularFileError) as info:
        read_bounded(link, 100, follow_links=False)  # not even opened
    assert info.value.kind == "a symbolic link" and _one_line(info.value, link)


def test_a_symbolic_link_to_a_file_is_read_only_when_links_are_followed(tmp_path: Path) -> None:
    (tmp_path / "file").write_bytes(b"abc")
    (tmp_path / "link").symlink_to(tmp_path / "file")
    assert read_bounded(tmp_path / "link", 3) == b"abc"
    with pytest.raises(NotARegularFileError, match="is a symbolic link, not a regular file"):
        read_bounded(tmp_path / "link", 3, follow_links=False)


def test_a_folder_and_a_device_are_refused_by_kind(tmp_path: Path) -> None:
    for follow_links in (True, False):
        with pytest.raises(NotARegularFileError) as info:
            read_bounded(tmp_path, 100, follow_links=follow_links)
        assert info.value.kind == "a folder" and _one_line(info.value, tmp_path)
    if os.path.exists(os.devnull) and not os.path.isfile(os.devnull):
        with pytest.raises(NotARegularFileError) as info:
            read_text(os.devnull, 100)
        assert info.value.kind == "a character device"


def test_a_missing_file_is_the_os_error() -> None:
    with pytest.raises(FileNotFoundError):
        read_bounded("/nonexistent/robot.json", 100)
    with pytest.raises(FileNotFoundError):
        read_bounded("/nonexistent/robot.json", 100, follow_links=False)


def test_an_oversize_file_is_refused_unread(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "huge"
    with open(path, "wb") as f:
        f.truncate(2**40)  # sparse: costs no disk; reading it would take hours
    with monkeypatch.context() as patch, pytest.raises(FileTooLargeError) as info:
        patch.setattr(files.os, "read", lambda *_: pytest.fail("read a byte of it"))
        read_bounded(path, 2**20)
    assert (info.value.size, info.value.max_bytes) == (2**40, 2**20)
    assert _one_line(info.value, path)


def test_a_file_that_grows_past_the_bound_while_read_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "growing"
    path.write_bytes(b"x" * 11)
    real = os.fstat

    def small(fd: int) -> os.stat_result:  # the size seen before it grew
        st = real(fd)
        return os.stat_result((st.st_mode, st.st_ino, st.st_dev, st.st_nlink, st.st_uid,
                               st.st_gid, 3, st.st_atime, st.st_mtime, st.st_ctime))

    with monkeypatch.context() as patch, pytest.raises(FileTooLargeError) as info:
        patch.setattr(files.os, "fstat", small)
        read_bounded(path, 10)
    assert info.value.size is None and _one_line(info.value, path)
    assert read_bounded(path, 11) == b"x" * 11


@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=300), bound=st.integers(0, 300))
def test_a_regular_file_is_read_whole_within_its_bound(data: bytes, bound: int) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "f"
        path.write_bytes(data)
        for follow_links in (True, False):
            if len(data) <= bound:
                assert read_bounded(path, bound, follow_links=follow_links) == data
            else:
                with pytest.raises(FileTooLargeError) as info:
                    read_bounded(path, bound, follow_links=follow_links)
                assert info.value.size == len(data)


@settings(max_examples=60, deadline=None)
@given(data=st.one_of(st.binary(max_size=64), st.text(max_size=32).map(
    lambda t: t.encode("utf-8", "surrogatepass"))))
def test_text_is_strict_utf8(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "t"
        path.write_bytes(data)
        try:
            expected = data.decode("utf-8")
        except UnicodeDecodeError as error:
            with pytest.raises(UnicodeDecodeError) as info:
                read_text(path, 64 * 4)
            assert info.value.start == error.start  # the offset of the first bad byte
        else:
            assert read_text(path, 64 * 4) == expected


def test_non_utf8_text_names_the_offset(tmp_path: Path) -> None:
    path = tmp_path / "latin.json"
    path.write_bytes("caf\u00e9".encode("latin-1"))
    with pytest.raises(UnicodeDecodeError) as info:
        read_text(path, 100)
    assert info.value.start == 3 and info.value.object[3] == 0xE9
    assert read_bounded(path, 100) == b"caf\xe9"  # the bytes themselves are fine
