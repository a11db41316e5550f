"""Reading a file that someone else wrote: bounded, without waiting, refusing what is not a file.

The one home of the rule that every reader of a user's or a received folder's file follows (a
robot JSON file, a policy file, a results folder's settings, snapshots and policies):

* the file is opened without waiting (``O_NONBLOCK``), so a FIFO opens at once, with no writer,
  and is then refused: a FIFO, socket, device or folder given as a file is an error, never a hang;
* its kind and size are checked on the open file (``fstat``, no race with a swap of the name)
  before a byte is read, and never more than the bound + 1 bytes are read, so a file that grows
  while it is read is refused too;
* a symbolic link is refused when asked (``follow_links=False``: a results folder's files);
* :func:`read_text` decodes strict UTF-8.

It lives in the lowest layer (the description) so that every layer above may use it. Each caller
turns these errors into its own one-line message.
"""

from __future__ import annotations

import os
import stat

__all__ = ["FileTooLargeError", "NotARegularFileError", "file_kind", "read_bounded", "read_text"]

_FLAGS = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
          | getattr(os, "O_BINARY", 0))
_CHUNK = 2**24
"""Bytes per ``read`` call. Bytes."""

_KINDS = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISDIR, "a folder"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"))


def file_kind(mode: int) -> str:
    """What a file that is not a regular one is, for messages (``"a FIFO"``, ``"a folder"``...)."""
    return next((text for test, text in _KINDS if test(mode)), "not a regular file")


class NotARegularFileError(OSError):
    """A file that is not a regular file.

    Attributes:
        kind: What it is (:func:`file_kind`: ``"a FIFO"``, ``"a folder"``...).
        path: The file (not ``filename``, which would change the one-line message).
    """

    def __init__(self, kind: str, name: str) -> None:
        super().__init__(f"{name} is {kind}, not a regular file")
        self.kind = kind
        self.path = name


class FileTooLargeError(OSError):
    """A file larger than its bound.

    Attributes:
        size: The file's size when it was checked, or ``None`` when it grew past the bound while
            it was read. Bytes.
        max_bytes: The bound. Bytes.
        path: The file.
    """

    def __init__(self, name: str, size: int | None, max_bytes: int) -> None:
        found = "grew" if size is None else f"is {size} bytes"
        super().__init__(f"{name} {found}, larger than the {max_bytes}-byte bound")
        self.size = size
        self.max_bytes = max_bytes
        self.path = name


def read_bounded(path: str | os.PathLike[str], max_bytes: int, *,
                 follow_links: bool = True) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them (see the module).

    Args:
        path: The file.
        max_bytes: The largest size accepted. Bytes.
        follow_links: ``False``: a symbolic link in the file's own place is refused, not followed
            (links in the folders above it are followed either way).

    Raises:
        NotARegularFileError: a FIFO, socket, device or folder (or a symbolic link, with
            ``follow_links=False``); a FIFO is refused, never waited on.
        FileTooLargeError: larger than ``max_bytes`` (refused unread), or grew past it while read.
        OSError: missing or unreadable (``FileNotFoundError``, ``PermissionError``...).
    """
    name = os.fspath(path)
    try:
        fd = os.open(name, _FLAGS if follow_links else _FLAGS | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        if not follow_links and os.path.islink(name):  # O_NOFOLLOW's ELOOP, said plainly
            raise NotARegularFileError("a symbolic link", name) from None
        raise
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise NotARegularFileError(file_kind(st.st_mode), name)
        if st.st_size > max_bytes:
            raise FileTooLargeError(name, st.st_size, max_bytes)
        chunks, left = [], max_bytes + 1
        while left > 0:
            chunk = os.read(fd, min(left, _CHUNK))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
    finally:
        os.close(fd)
    if left <= 0:  # more than max_bytes: it grew after the check
        raise FileTooLargeError(name, None, max_bytes)
    return b"".join(chunks)


def read_text(path: str | os.PathLike[str], max_bytes: int, *, follow_links: bool = True) -> str:
    """The text of the UTF-8 file ``path`` (:func:`read_bounded`'s rules, then strict UTF-8).

    Raises:
        UnicodeDecodeError: not UTF-8 (its ``start`` is the offset of the first bad byte).
        NotARegularFileError, FileTooLargeError, OSError: as :func:`read_bounded`.
    """
    return read_bounded(path, max_bytes, follow_links=follow_links).decode("utf-8")
