"""The files and folders pfbench writes: plain names, paths proven to lie inside the folder that
owns them, atomic writes that leave nothing behind when they fail, and folder locks.

Every folder pfbench writes into is one the user named (``--out``, ``--results``) or a plain
child of one (``<results>/<name>``). Before a folder is deleted or replaced, :func:`remove_tree`
and :func:`replace_tree` check that it lies inside the folder that owns it (symbolic links
resolved) and is not a link itself. A run holds :class:`FolderLock` on its folder from the first
file it writes to the last, so two runs never write into one folder.
"""
from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from .errors import UserError

NAME_MAX_BYTES = 120


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a results folder's name (one plain path component), or None."""
    if not isinstance(name, str) or not name.strip():
        return "expected a non-empty name"
    if "\x00" in name:
        return "a name cannot contain a NUL character"
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        return "a name cannot contain control characters"
    if "/" in name or "\\" in name:
        return (f"expected one plain folder name, got {name!r}: no '/' or '\\' (the results go "
                "to <results>/<name>; choose the folder itself with --out)")
    if name in (".", "..") or name.startswith("."):
        return f"expected a folder name that does not start with '.', got {name!r}"
    if name != name.strip():
        return f"expected a name without leading or trailing spaces, got {name!r}"
    if len(name.encode("utf-8", "surrogatepass")) > NAME_MAX_BYTES:
        return f"expected a name of at most {NAME_MAX_BYTES} bytes"
    return None


def child(root: Path, name: str, what: str = "name") -> Path:
    """``root / name`` for a plain ``name`` (else a UserError naming ``what``)."""
    problem = name_problem(name)
    if problem:
        raise UserError(f"{what}: {problem}")
    return Path(root) / name


def inside(path: Path, root: Path) -> bool:
    """Whether ``path`` lies strictly inside ``root`` (both resolved, links followed)."""
    try:
        p = Path(path).resolve()
        r = Path(root).resolve()
    except (OSError, RuntimeError):
        return False
    return p != r and p.is_relative_to(r)


def _owned(path: Path, root: Path, verb: str) -> None:
    path = Path(path)
    if path.is_symlink() or not inside(path, root):
        raise UserError(f"refusing to {verb} {path}: it does not lie inside {root}")


def remove_tree(path: Path, root: Path) -> None:
    """Remove the folder ``path``, which must lie inside ``root`` and not be a link."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return
    _owned(path, root, "remove")
    if not path.is_dir():
        raise UserError(f"refusing to remove {path}: not a folder")
    shutil.rmtree(path)


def replace_tree(src: Path, dst: Path, root: Path) -> None:
    """Put the folder ``src`` in the place of ``dst`` (both inside ``root``): the old ``dst`` is
    moved aside first and removed only once ``src`` is in place."""
    src, dst = Path(src), Path(dst)
    _owned(src, root, "move")
    old = None
    if dst.exists() or dst.is_symlink():
        _owned(dst, root, "replace")
        old = dst.with_name(f".{dst.name}.old{os.getpid()}")
        remove_tree(old, root)
        dst.rename(old)
    try:
        src.rename(dst)
    except OSError:
        if old is not None and not dst.exists():
            old.rename(dst)
        raise
    if old is not None:
        remove_tree(old, root)


def write_through_temp(path: Path, write, suffix: str = "") -> None:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``: never
    half-written; a failed write (a full disk) removes the temporary file."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}{suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def atomic_write(path: Path, data: str | bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`write_through_temp`), synced to disk."""
    def write(tmp: Path) -> None:
        if isinstance(data, bytes):
            fh = open(tmp, "wb")
        else:
            fh = open(tmp, "w", encoding="utf-8", newline="")
        with fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())

    write_through_temp(path, write)


def ensure_folder(folder: Path, what: str = "--out") -> Path:
    """Create ``folder`` (and its parents) or say in one line why it cannot be."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{what} {folder}: exists and is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise UserError(f"{what} {folder}: a part of the path is a file, not a folder") from None
    except OSError as exc:
        raise UserError(f"{what} {folder}: cannot create it: {exc.strerror}") from None
    return folder


def os_error_line(exc: OSError) -> str:
    """One line for a filesystem error: the path and what went wrong."""
    what = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        what += " (the disk is full; the files of earlier runs are unchanged)"
    elif exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM):
        what += " (choose a folder you can write with --out or --results)"
    name = exc.filename or ""
    return f"{name}: {what}" if name else what


# ---------------------------------------------------------------- locks

_HELD: dict[str, list] = {}      # resolved lock path -> [fd, depth]
LOCK_NAME = ".pfbench.lock"


class FolderLock:
    """An exclusive lock on a folder for as long as pfbench writes into it.

    The lock is ``fcntl.flock`` on ``<folder>/.pfbench.lock``, which holds the holder's pid. The
    kernel releases it when the process ends, however it ends, so a crash never leaves a stale
    lock; the file is removed on release (after checking, on acquiring, that the file locked is
    still the one at the path). A second process that asks for a held lock gets a UserError naming
    the holder's pid. Nested locks of one folder in one process are counted, not taken twice. A
    folder the lock had to create is removed again on release if nothing was written into it.
    """

    def __init__(self, folder: Path, what: str = "results folder"):
        self.folder = Path(folder)
        self.what = what
        self.path = self.folder / LOCK_NAME
        self.key = None

    def acquire(self) -> "FolderLock":
        import fcntl

        created = not self.folder.exists()
        ensure_folder(self.folder, self.what)
        self.key = str(self.path.resolve())
        held = _HELD.get(self.key)
        if held is not None:
            held[1] += 1
            return self
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                raise UserError(f"{self.what} {self.folder}: cannot write in it: "
                                f"{exc.strerror}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                try:
                    pid = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
                finally:
                    os.close(fd)
                raise UserError(f"{self.what} {self.folder} is in use by another pfbench run "
                                f"(pid {pid}); wait for it to end, or choose another folder")
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)            # the holder removed the file as we opened it: try again
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:
            pass                    # a full disk: the lock holds without the pid in it
        _HELD[self.key] = [fd, 1, created]
        return self

    def release(self) -> None:
        held = _HELD.get(self.key)
        if held is None:
            return
        held[1] -= 1
        if held[1] > 0:
            return
        del _HELD[self.key]
        try:            # remove the file only while it is still ours (the folder may have moved)
            if os.stat(self.path).st_ino == os.fstat(held[0]).st_ino:
                self.path.unlink()
        except OSError:
            pass
        os.close(held[0])
        if held[2]:             # a folder the lock made, left empty (the run failed at once)
            try:
                self.folder.rmdir()
            except OSError:
                pass

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def close_inherited_locks() -> None:
    """In a forked worker: close the lock files inherited from the parent (the parent keeps its
    locks; a worker that outlives it must not)."""
    for fd, *_ in list(_HELD.values()):
        try:
            os.close(fd)
        except OSError:
            pass
    _HELD.clear()
