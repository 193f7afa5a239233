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


def link_below(path: Path, root: Path) -> Path | None:
    """The first part of ``path`` below ``root`` (``root`` itself not included: the user named
    it) that is a symbolic link, or None. ``path`` must be ``root`` or lie below it by name."""
    path, root = Path(path), Path(root)
    try:
        rel = path.relative_to(root)
    except ValueError:
        return path
    cur = root
    for part in rel.parts:
        cur = cur / part
        if cur.is_symlink():
            return cur
    return None


def own_folder(path: Path, root: Path, what: str = "folder") -> Path:
    """``path`` (``root`` or a folder below it by name) as a folder pfbench may write into or
    remove: no part of it below ``root`` is a symbolic link, and it lies inside ``root`` (else a
    one-line UserError). It need not exist yet."""
    path, root = Path(path), Path(root)
    link = link_below(path, root)
    if link is not None:
        raise UserError(f"{what} {link}: is a symbolic link (or lies outside {root}); pfbench "
                        "writes only into real folders inside the folder you named: remove the "
                        "link")
    if path.exists() and not path.is_dir():
        raise UserError(f"{what} {path}: exists and is not a folder")
    return path


def remove_tree(path: Path, root: Path) -> None:
    """Remove the folder ``path``, which must lie inside ``root`` and not be a link."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return
    _owned(path, root, "remove")
    if not path.is_dir():
        raise UserError(f"refusing to remove {path}: not a folder")
    shutil.rmtree(path)


OLD_TAG = ".old"


def aside_names(dst: Path) -> list[Path]:
    """The folders ``replace_tree`` moved ``dst`` aside to (``.NAME.old<pid>``) and did not
    remove: a run killed between its renames leaves one. Newest first."""
    dst = Path(dst)
    prefix = f".{dst.name}{OLD_TAG}"
    try:
        found = [p for p in dst.parent.iterdir()
                 if p.name.startswith(prefix) and p.name[len(prefix):].isdigit()
                 and p.is_dir() and not p.is_symlink()]
    except OSError:
        return []
    return sorted(found, key=lambda p: p.stat().st_mtime_ns, reverse=True)


def recover_aside(dst: Path, root: Path, warn=None, clean: bool = True) -> Path | None:
    """Undo what a ``replace_tree`` killed between its renames left: when ``dst`` is missing and
    ``.NAME.old<pid>`` holds it, move it back (and say so to ``warn``); when ``dst`` is there, the
    copies moved aside are the replaced results: removed. Call it holding the lock of ``root``.
    Returns the folder restored from, or None."""
    dst, root = Path(dst), Path(root)
    found = aside_names(dst)
    if not found:
        return None
    restored = None
    if not dst.exists() and not dst.is_symlink():
        restored = found.pop(0)
        _owned(restored, root, "restore")
        restored.rename(dst)
        if warn:
            warn(f"{dst}: restored from {restored.name}, where a run killed while it replaced "
                 "the folder had left it")
    for old in found if clean else ():
        remove_tree(old, root)
    return restored


def replace_tree(src: Path, dst: Path, root: Path) -> None:
    """Put the folder ``src`` in the place of ``dst`` (both inside ``root``): the old ``dst`` is
    moved aside first (``.NAME.old<pid>``, which :func:`recover_aside` restores when a kill
    leaves it there) and removed only once ``src`` is in place."""
    src, dst = Path(src), Path(dst)
    _owned(src, root, "move")
    old = None
    if dst.exists() or dst.is_symlink():
        _owned(dst, root, "replace")
        old = dst.with_name(f".{dst.name}{OLD_TAG}{os.getpid()}")
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


def left_by_a_kill(name: str) -> bool:
    """Whether a file name is one of write_through_temp's temporary files (``.NAME.tmpPID``):
    what a write killed half-way leaves beside the file it was writing."""
    return name.startswith(".") and ".tmp" in name


def file_digest(path: Path) -> bytes:
    """The SHA-256 of a file's bytes (32 bytes): what a cache's key takes of a file (the replay
    records, the drawn figures, the report's figures). OSError where it cannot be read."""
    import hashlib
    return hashlib.sha256(Path(path).read_bytes()).digest()


def write_through_temp(path: Path, write, suffix: str = "") -> None:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``: never
    half-written; a failed write (a full disk) removes the temporary file."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}{suffix}")
    try:
        _new_file(tmp)
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def _new_file(tmp: Path) -> None:
    """Create ``tmp`` as a new empty file of ours: a leftover of that name (a killed run of the
    same pid) is removed first, and a symbolic link put there is never followed."""
    for _ in range(3):
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        except FileExistsError:
            if tmp.is_dir() and not tmp.is_symlink():
                raise
            tmp.unlink()            # a file or a link (the link itself, not its target)
            continue
        os.close(fd)
        return
    raise FileExistsError(errno.EEXIST, "cannot create a temporary file", str(tmp))


def atomic_write(path: Path, data: str | bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`write_through_temp`), synced to disk."""
    def write(tmp: Path) -> None:
        fd = os.open(tmp, os.O_WRONLY | os.O_TRUNC | os.O_NOFOLLOW)
        if isinstance(data, bytes):
            fh = open(fd, "wb")
        else:
            fh = open(fd, "w", encoding="utf-8", newline="")
        with fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())

    write_through_temp(path, write)


def make_folders(folder: Path, what: str = "--out") -> list[Path]:
    """Create ``folder`` and its missing parents, or say in one line why it cannot be (a part
    that is a file, a name too long, no permission), leaving none of the folders it made.
    Returns the folders it made, deepest first (what :func:`remove_made` takes)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{what} {folder}: exists and is not a folder")
    if folder.is_symlink() and not folder.exists():
        raise UserError(f"{what} {folder}: a link to a folder that does not exist")
    missing = []
    cur = folder
    while not cur.exists() and not cur.is_symlink() and cur != cur.parent:
        missing.append(cur)
        cur = cur.parent
    made: list[Path] = []
    try:
        for p in reversed(missing):
            p.mkdir()
            made.insert(0, p)
        if not folder.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, "not a folder", str(folder))
    except (FileExistsError, NotADirectoryError):
        remove_made(made)
        raise UserError(f"{what} {folder}: a part of the path is a file, not a folder") from None
    except OSError as exc:
        remove_made(made)
        raise UserError(f"{what} {folder}: cannot create it: {exc.strerror}") from None
    return made


def remove_made(made: list[Path]) -> None:
    """Remove the folders of ``made`` (deepest first) that are still empty."""
    for p in made:
        try:
            p.rmdir()
        except FileNotFoundError:
            continue
        except OSError:
            break


def ensure_folder(folder: Path, what: str = "--out") -> Path:
    """Create ``folder`` (and its parents) or say in one line why it cannot be."""
    make_folders(folder, what)
    return Path(folder)


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


def _in_use(fd: int, what: str, folder, advice: str = "") -> UserError:
    """The error for a folder whose lock another run holds, naming that run's pid (the lock
    file's text); closes ``fd``, the lock file."""
    try:
        pid = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
    except OSError:
        pid = "unknown"
    finally:
        os.close(fd)
    return UserError(f"{what} {folder} is in use by another pfbench run (pid {pid}); wait for "
                     f"it to end{advice}")


class FolderLock:
    """An exclusive lock on a folder for as long as pfbench writes into it.

    The lock is ``fcntl.flock`` on ``<folder>/.pfbench.lock``, which holds the holder's pid. The
    kernel releases it when the process ends, however it ends, so a crash never leaves a stale
    lock; the file is removed on release (after checking, on acquiring, that the file locked is
    still the one at the path). A second process that asks for a held lock gets a UserError naming
    the holder's pid. Nested locks of one folder in one process are counted, not taken twice. The
    lock file is opened without following links: a link there is refused. ``root``: the folder
    the user named, that ``folder`` lies in by name; no part of ``folder`` below it may be a
    link. The folders the lock had to create (parents included) are removed again on release if
    nothing was written into them, or when the run failed before a trial finished.
    """

    def __init__(self, folder: Path, what: str = "results folder", root: Path | None = None):
        self.folder = Path(folder)
        self.what = what
        self.root = Path(root) if root is not None else None
        self.path = self.folder / LOCK_NAME
        self.key = None

    def acquire(self) -> "FolderLock":
        import fcntl

        if self.root is not None:           # a folder pfbench names inside one the user named
            own_folder(self.folder, self.root, self.what)
        made = make_folders(self.folder, self.what)
        try:
            self.key = str(self.path.resolve())
        except (OSError, RuntimeError) as exc:
            remove_made(made)
            raise UserError(f"{self.what} {self.folder}: {exc}") from None
        held = _HELD.get(self.key)
        if held is not None:
            held[1] += 1
            return self
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
            except OSError as exc:
                remove_made(made)
                if exc.errno == errno.ELOOP or self.path.is_symlink():
                    raise UserError(f"{self.path}: the lock file is a symbolic link; pfbench "
                                    "never writes through one: remove it") from None
                raise UserError(f"{self.what} {self.folder}: cannot write in it: "
                                f"{exc.strerror}") from None
            if not _regular(fd):
                os.close(fd)
                remove_made(made)
                raise UserError(f"{self.path}: the lock file is not a plain file: remove it")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise _in_use(fd, self.what, self.folder, ", or choose another folder") from None
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
        _HELD[self.key] = [fd, 1, made]
        return self

    def release(self, failed: bool = False) -> None:
        held = _HELD.get(self.key)
        if held is None:
            return
        held[1] -= 1
        if held[1] > 0:
            return
        del _HELD[self.key]
        if failed and held[2] and _nothing_kept(self.folder):
            # a run that failed before finishing a trial, in a folder it made: leave no folder
            shutil.rmtree(self.folder, ignore_errors=True)
        try:            # remove the file only while it is still ours (the folder may have moved)
            if os.stat(self.path).st_ino == os.fstat(held[0]).st_ino:
                self.path.unlink()
        except OSError:
            pass
        os.close(held[0])
        remove_made(held[2])    # the folders the lock made, left empty (the run failed at once)

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, exc_type, exc, tb) -> None:
        # an interrupted run keeps its finished trials (--resume): only an error counts
        self.release(failed=exc_type is not None and issubclass(exc_type, Exception)
                     and exc_type.__name__ != "Interrupted")


# what a run writes before its first trial finishes: nothing of these is worth keeping
_SCAFFOLD = {LOCK_NAME, "run.json", "trials.partial.csv", "timings.partial.csv"}


def _nothing_kept(folder: Path) -> bool:
    """Whether ``folder`` holds only a run's scaffolding with no finished trial (see release)."""
    try:
        for p in Path(folder).rglob("*"):
            if p.is_symlink():
                return False
            if p.is_dir():
                continue
            rel = p.relative_to(folder)
            if rel.parts[0] == "traces.partial":
                continue
            if len(rel.parts) > 1 or p.name not in _SCAFFOLD:
                return False
            if p.name.endswith(".partial.csv"):
                with open(p, "rb") as fh:
                    if fh.read(1 << 16).count(b"\n") > 1:
                        return False
    except OSError:
        return False
    return True


def _regular(fd: int) -> bool:
    import stat
    try:
        return stat.S_ISREG(os.fstat(fd).st_mode)
    except OSError:
        return False


def close_inherited_locks() -> None:
    """In a forked worker: close the lock files inherited from the parent (the parent keeps its
    locks; a worker that outlives it must not)."""
    for fd, *_ in list(_HELD.values()):
        try:
            os.close(fd)
        except OSError:
            pass
    _HELD.clear()


class not_in_use:
    """While held: ``folder`` is not being rewritten by another pfbench run (its lock is not
    held), checked without writing into it (a shared lock on its lock file, where there is one;
    a read-only folder is fine)."""

    def __init__(self, folder: Path, what: str = "results folder"):
        self.folder = Path(folder)
        self.what = what
        self.fd = None

    def __enter__(self) -> "not_in_use":
        import fcntl
        path = self.folder / LOCK_NAME
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
        except OSError:
            return self             # no lock file (or a link, which no run holds): not in use
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            raise _in_use(fd, self.what, self.folder) from None
        self.fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def require_regular(path: Path) -> None:
    """A one-line UserError when ``path`` exists and is not a regular file (a FIFO, whose reading
    would wait for ever for a writer; a device such as /dev/zero, which never ends; a socket; a
    folder). A missing path passes: its reader says what is missing."""
    import stat as _stat
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if _stat.S_ISREG(mode):
        return
    kind = ("a FIFO (named pipe)" if _stat.S_ISFIFO(mode) else
            "a device" if _stat.S_ISCHR(mode) or _stat.S_ISBLK(mode) else
            "a socket" if _stat.S_ISSOCK(mode) else
            "a folder" if _stat.S_ISDIR(mode) else "not a plain file")
    raise UserError(f"{path}: is {kind}, not a regular file: pfbench reads only files")


def is_regular(path: Path) -> bool:
    """Whether ``path`` is a regular file (links followed); False when it is missing."""
    try:
        require_regular(path)
    except UserError:
        return False
    return Path(path).is_file()
