"""Writes that survive a kill, a second writer and a full disk.

*Staging.* A writer (one :func:`wdendrite.io.atomic_write`, one command's set of outputs, one
tiled image) makes its temporary files under names of its own, ``.wdendrite-TOKEN-K.NAME``
(TOKEN: 16 random hex digits), and first an *owner file* ``.wdendrite-TOKEN.run`` in each
folder it stages in, which it holds locked (``flock``) while it lives: the system drops the
lock when the process ends, however it ends (SIGKILL included). :func:`sweep` removes the
files of tokens whose owner file nobody holds, and never a file of a live writer or one that
is not named so.

*Sets of renames.* Before a writer renames several staged files onto their paths, it records
the renames in the owner file of its first folder (a journal; the owner files of its other
folders point there). A writer killed part way through leaves the journal unlocked, and
:func:`sweep` completes the renames: every path of the set then holds its new file, except a
path that someone changed after the journal was written, which is left as it is.

*Locks on outputs.* :func:`locked` holds an exclusive lock on each output, a file
``.wdendrite-lock.NAME`` beside it that holds the locker's process id, so that a second
writer of the same output stops at once with a message naming it.

*Disk space.* :func:`check_space` compares what files will take with the free space of
their disks before they are made; :func:`reserve` allocates a file's bytes before they are
written, so that a full disk is an error when the file is made, not a signal later (a write
through a memory map of a sparse file meets a full disk as SIGBUS).

Where the system has no ``flock`` (Windows) or a file system refuses it, writers go on
unlocked, and sweeps leave their files alone: they cannot tell a live writer from a dead one.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import shutil
import stat
import time
import zlib
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None

PREFIX = ".wdendrite-"
"""The start of the name of every file a writer stages, its owner files and output locks."""
_OWNED = re.compile(r"\.wdendrite-([0-9a-f]{16})(?:\.run|-\d+\..*)", re.S)
_LOCK = PREFIX + "lock."
NAME_BYTES = 255  # the longest file name common file systems take, in bytes


def fitted(name: str, room: int) -> str:
    """``name`` in at most ``room`` bytes: a longer one is cut, marked with a hash of the whole
    name (two long names with a common start stay apart) and keeps its suffix when that is short."""
    raw = os.fsencode(name)  # bytes as the file system takes them (undecodable names too)
    if len(raw) <= room:
        return name
    suffix = os.fsencode(Path(name).suffix)
    suffix = suffix if len(suffix) <= 16 else b""
    mark = b"~" + format(zlib.crc32(raw), "08x").encode()
    cut = raw[: max(0, room - len(mark) - len(suffix))]
    try:
        raw.decode()
        short = cut.decode(errors="ignore")  # a UTF-8 name: cut at a character boundary
    except UnicodeDecodeError:
        short = os.fsdecode(cut)  # other bytes, escaped as the file system functions expect
    return short + os.fsdecode(mark + suffix)


def identity(path) -> str:
    """What tells the file at ``path`` from any other: device and inode (a rename keeps them), and
    for a file also its size and modification time (a file rewritten in place changes them)."""
    st = os.lstat(path)
    if stat.S_ISDIR(st.st_mode):
        return f"{st.st_dev}:{st.st_ino}"
    return f"{st.st_dev}:{st.st_ino}:{st.st_size}:{st.st_mtime_ns}"


def _flock(fd: int, *, wait: bool) -> bool | None:
    """Lock ``fd`` exclusively: True when held, False when another process holds it, None where
    the system or the file system has no such locks."""
    if fcntl is None:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        return True
    except BlockingIOError:
        return False
    except OSError as exc:
        if exc.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL):
            return None
        raise


def _same_file(fd: int, path) -> bool:
    """Whether ``path`` still names the file open as ``fd`` (a sweep may have removed it meanwhile)."""
    try:
        st, ours = os.lstat(path), os.fstat(fd)
    except FileNotFoundError:
        return False
    return (st.st_dev, st.st_ino) == (ours.st_dev, ours.st_ino)


def _release(fd: int, path) -> None:
    """Delete the lock file ``path`` (if it is still the file open as ``fd``), then close ``fd``:
    in this order, no other process can take the lock of a file about to be deleted."""
    if fcntl is None:  # (Windows: no locks, and an open file cannot be deleted)
        os.close(fd)
        Path(path).unlink(missing_ok=True)
        return
    try:
        if _same_file(fd, path):
            os.unlink(path)
    finally:
        os.close(fd)


def _remove(path) -> None:
    """Delete a file, a link or a folder (a Zarr store moved aside) at ``path``, if there is one."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
        else:
            os.unlink(path)
    except FileNotFoundError:
        pass


# --------------------------------------------------------------------------- staging


class Staging:
    """The temporary files of one writer, renamed into place together (see the module's notes).

    Use it as a context manager: on leaving, every file it staged that is still there is
    deleted, then its owner files.
    """

    def __init__(self):
        self.token = secrets.token_hex(8)
        self._count = 0
        self._owners: dict[str, tuple[int, str]] = {}  # folder -> (descriptor, owner file)
        self._journal: tuple[int, str] | None = None  # the owner file that holds the journal
        self._made: list[Path] = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _owner(self, folder: str) -> None:
        """Make and lock this writer's owner file in ``folder`` (once), before any file it stages there."""
        folder = os.path.abspath(folder)
        if folder in self._owners:
            return
        path = os.path.join(folder, f"{PREFIX}{self.token}.run")
        while True:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            held = _flock(fd, wait=True)
            if held is None or _same_file(fd, path):
                break
            os.close(fd)  # a sweep took it for a dead writer's (before it was locked) and removed it
        self._owners[folder] = (fd, path)
        if self._journal is None:
            self._journal = (fd, path)
        os.write(fd, json.dumps({"journal": self._journal[1]}).encode())

    def name(self, path) -> Path:
        """A new name beside ``path`` for a file of this writer (nothing is made there): ``path``'s
        name, shortened to fit, after this writer's prefix. The file is deleted on leaving."""
        path = Path(path)
        self._owner(path.parent)
        self._count += 1
        head = f"{PREFIX}{self.token}-{self._count}."
        made = path.with_name(head + fitted(path.name, NAME_BYTES - len(head)))
        self._made.append(made)
        return made

    def temporary(self, path, mode: int) -> Path:
        """A new empty file beside ``path`` to stage it in, with permissions ``mode`` plus the
        owner's read and write (writers may read back); give it its final mode before the rename."""
        while True:
            tmp = self.name(path)
            try:
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
                break
            except FileExistsError:
                continue
        os.chmod(tmp, mode | stat.S_IRUSR | stat.S_IWUSR)
        return tmp

    def commit(self, staged) -> None:
        """Rename every ``(tmp, path)`` of ``staged`` onto its path, all or none.

        The renames are first recorded in the journal: a kill part way leaves them for
        :func:`sweep` to complete. A rename that fails puts back what the earlier ones replaced
        (a file a rename replaces is kept under a hard link, or moved aside where the file
        system has no hard links, until every rename has succeeded) and raises its error.
        """
        plan = []
        for tmp, path in staged:
            path = Path(path)
            old = identity(path) if os.path.lexists(path) else None
            keep = self.name(path) if old is not None else None
            # (absolute: the sweep that completes them may run in another folder)
            plan.append((os.path.abspath(tmp), os.path.abspath(path), old, keep and os.path.abspath(keep)))
        self._write_journal(plan)
        done = []  # (path, where the file it replaced is kept, or None: there was none)
        try:
            for tmp, path, _, keep in plan:
                _rename_keeping(tmp, path, keep, done)
        except BaseException:
            for path, keep in reversed(done):
                if keep is not None:
                    os.replace(keep, path)
                else:
                    Path(path).unlink(missing_ok=True)
            self._write_journal([])  # (a kill now leaves nothing to complete)
            raise
        for folder in dict.fromkeys(os.path.dirname(p) for p, _ in done):
            sync_folder(folder)
        self._write_journal([])
        for _, keep in done:
            if keep is not None:
                Path(keep).unlink(missing_ok=True)

    def _write_journal(self, plan: list) -> None:
        fd, path = self._journal
        folders = sorted(self._owners)
        data = json.dumps({"journal": path, "folders": folders, "renames": plan}).encode()
        os.ftruncate(fd, 0)
        write_at(fd, data, 0)
        os.fsync(fd)

    def close(self) -> None:
        """Delete what this writer staged and did not rename, then its owner files (the journal's last)."""
        for made in self._made:
            _remove(made)
        self._made.clear()
        owners = sorted(self._owners.values(), key=lambda o: o == self._journal)
        for fd, path in owners:
            _release(fd, path)
        self._owners.clear()
        self._journal = None


def _rename_keeping(tmp: str, path: str, keep: str | None, done: list) -> None:
    """Rename ``tmp`` onto ``path``, the file there first kept at ``keep`` (a hard link, else moved)."""
    linked = False
    if keep is not None:
        try:
            os.link(path, keep, follow_symlinks=False)  # (a link is kept as a link)
            linked = True
        except (OSError, NotImplementedError):  # no hard links here: the old file moves aside instead
            os.replace(path, keep)
    try:
        os.replace(tmp, path)
    except BaseException:
        if linked:  # path is still the old file (renaming a link onto it would do nothing)
            os.unlink(keep)
        elif keep is not None:
            os.replace(keep, path)
        raise
    done.append((path, keep))


def sync_folder(folder) -> None:
    """Flush ``folder``'s entries (the renames just made in it) to the disk, where the system allows."""
    if os.name == "nt":
        return  # folders cannot be opened for a flush there; NTFS logs renames itself
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems refuse to flush a folder: the renames stand, only less durably
        pass
    finally:
        os.close(fd)


# --------------------------------------------------------------------------- sweeping


def sweep(folder) -> None:
    """Finish what killed writers left in ``folder``: complete the renames their journals record,
    then delete their staged files, owner files and output locks. Files of live writers, and
    files not named as a writer names them, are left alone; so is anything the sweep cannot do
    (it never raises for a file it could not delete)."""
    try:
        names = os.listdir(folder)
    except OSError:
        return
    tokens: dict[str, list[str]] = {}
    for name in names:
        m = _OWNED.fullmatch(name)
        if m:
            tokens.setdefault(m.group(1), []).append(name)
        elif name.startswith(_LOCK):
            _drop_stale_lock(os.path.join(folder, name))
    for token, found in tokens.items():
        try:
            _sweep_token(os.path.abspath(folder), token, found)
        except OSError:
            pass


def _sweep_token(folder: str, token: str, found: list[str]) -> None:
    owner = os.path.join(folder, f"{PREFIX}{token}.run")
    try:
        fd = os.open(owner, os.O_RDONLY)
    except FileNotFoundError:
        # no owner file: its writer had finished (or a sweep has just rolled its journal forward)
        for name in found:
            _remove(os.path.join(folder, name))
        return
    try:
        if _flock(fd, wait=False) is not True or not _same_file(fd, owner):
            return  # a live writer's (or one that cannot be told from one)
        pointer = _read_json(fd)
        journal = _read_journal(pointer.get("journal"), owner, fd)
        folders = [folder]
        if journal:
            _roll_forward(journal["renames"])
            folders = list(dict.fromkeys([folder, *journal["folders"]]))
        for f in folders:
            for name in _owned_in(f, token):
                if not name.endswith(".run"):
                    _remove(os.path.join(f, name))
        for f in folders:
            other = os.path.join(f, f"{PREFIX}{token}.run")
            if other != owner:
                _remove(other)
        os.unlink(owner)
    finally:
        os.close(fd)


def _owned_in(folder: str, token: str) -> list[str]:
    try:
        return [n for n in os.listdir(folder) if (m := _OWNED.fullmatch(n)) and m.group(1) == token]
    except OSError:
        return []


def _read_json(fd: int) -> dict:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        chunks = []
        while chunk := os.read(fd, 1 << 16):
            chunks.append(chunk)
        data = json.loads(b"".join(chunks))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _read_journal(where, owner: str, fd: int) -> dict | None:
    """The renames a dead writer recorded, read from its journal ``where`` (its owner file
    ``owner``, open as ``fd``, or the one of another folder, locked while read), or None."""
    if not isinstance(where, str):
        return None
    if where == owner:
        data = _read_json(fd)
    else:
        try:
            other = os.open(where, os.O_RDONLY)
        except OSError:
            return None  # gone: its sweep completed the renames
        try:
            if _flock(other, wait=False) is not True:
                return None
            data = _read_json(other)
        finally:
            os.close(other)
    renames, folders = data.get("renames"), data.get("folders")
    if not renames or not isinstance(renames, list) or not isinstance(folders, list):
        return None
    return {"renames": renames, "folders": [f for f in folders if isinstance(f, str)]}


def _roll_forward(renames: list) -> None:
    """Complete the renames of a journal: each staged file still there goes to its path, unless
    the path was changed after the journal was written (its file is then left as it is)."""
    for entry in renames:
        try:
            tmp, path, old, keep = entry
            if not os.path.lexists(tmp):
                continue  # renamed already
            now = identity(path) if os.path.lexists(path) else None
            if now == old or (now is None and keep is not None and os.path.lexists(keep)):
                os.replace(tmp, path)
        except (OSError, ValueError, TypeError):
            continue
    for folder in dict.fromkeys(os.path.dirname(e[1]) for e in renames if isinstance(e, list) and len(e) == 4):
        sync_folder(folder)


# --------------------------------------------------------------------------- locks on outputs


def lock_path(path) -> Path:
    """The file whose lock stands for the output ``path`` (see :func:`locked`)."""
    path = Path(path)
    return path.with_name(_LOCK + fitted(path.name, NAME_BYTES - len(_LOCK)))


_BUSY = "{path!r} is being written by another run of wdendrite ({holder}); wait until it has finished or write elsewhere"


@contextlib.contextmanager
def locked(paths, *, busy: str = _BUSY):
    """Hold an exclusive lock on each output in ``paths`` (a file ``.wdendrite-lock.NAME`` beside it,
    deleted on leaving) while the block runs.

    Raises:
        FileExistsError: another process holds one of the locks; the message is ``busy`` with
            ``{path}`` and ``{holder}`` (its process id) filled in. Nothing is locked then.
    """
    held = []
    try:
        for path in sorted({os.path.abspath(p) for p in paths}):
            held.append(_take(lock_path(path), path, busy))
        yield
    finally:
        for fd, where in reversed(held):
            _release(fd, where)


def _take(where: Path, path: str, busy: str) -> tuple[int, Path]:
    """Lock the file ``where`` for the output ``path``; ``(descriptor, where)``."""
    for tries in range(100):
        try:
            fd, mine = os.open(where, os.O_RDWR | os.O_CREAT, 0o644), True
        except PermissionError:  # another user's lock file (a lock needs no write access)
            fd, mine = os.open(where, os.O_RDONLY), False
        held = _flock(fd, wait=False)
        if held is None:  # no locks here: the writer goes on unprotected
            return fd, where
        if held and _same_file(fd, where):
            if mine:  # (the process id, for the message of a second writer)
                try:
                    os.ftruncate(fd, 0)
                    write_at(fd, str(os.getpid()).encode(), 0)
                except OSError:  # a full disk: the lock holds without it (the message says "another process")
                    pass
            return fd, where
        holder = None if held else _read_text(fd)
        os.close(fd)
        if not held and tries >= 5:  # held all along: by a writer, not a sweep (which holds one for an instant)
            who = f"process {holder}" if holder and holder.isdigit() else "another process"
            raise FileExistsError(busy.format(path=path, holder=who))
        if not held:
            time.sleep(0.02)
    raise FileExistsError(busy.format(path=path, holder="another process"))


def _read_text(fd: int) -> str:
    try:
        return os.pread(fd, 64, 0).decode(errors="replace").strip() if hasattr(os, "pread") else ""
    except OSError:
        return ""


def _drop_stale_lock(where: str) -> None:
    """Delete an output lock that nobody holds (its writer was killed)."""
    try:
        fd = os.open(where, os.O_RDONLY)
    except OSError:
        return
    try:
        if _flock(fd, wait=False) is True and _same_file(fd, where):
            os.unlink(where)
    except OSError:
        pass
    finally:
        os.close(fd)


# --------------------------------------------------------------------------- disk space


def _size(nbytes: int) -> str:
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.1f} {unit}"
    return f"{nbytes} bytes"


def free_bytes(folder) -> int:
    """The space free for this user on the disk that holds ``folder``, in bytes."""
    return shutil.disk_usage(folder).free


def check_space(needs: dict, *, free=None) -> None:
    """Raise ``OSError`` (ENOSPC) naming the file and the space needed when the files of ``needs``
    (``{path: bytes}``) do not fit the free space of their disks (``free(folder)``, in bytes),
    counting the files that share a disk together. ``free`` defaults to :func:`free_bytes`."""
    free = free or free_bytes
    disks: dict[int, list] = {}
    for path, nbytes in needs.items():
        folder = os.path.dirname(os.path.abspath(path))
        disks.setdefault(os.stat(folder).st_dev, []).append((path, nbytes, folder))
    for files in disks.values():
        total = sum(n for _, n, _ in files)
        have = free(files[0][2])
        if total > have:
            path = max(files, key=lambda f: f[1])[0]
            also = f" (with {len(files) - 1} more output{'s' if len(files) > 2 else ''} on that disk)" \
                if len(files) > 1 else ""
            raise OSError(errno.ENOSPC, f"could not write {str(path)!r}: it needs {_size(total)}{also}, but its "
                                        f"disk has {_size(have)} free")


def reserve(fd: int, nbytes: int, path) -> None:
    """Allocate the first ``nbytes`` bytes of the file open as ``fd`` on the disk
    (``posix_fallocate``; by writing zeros where the system or file system has no such call),
    so that what is written there later cannot meet a full disk.

    Raises:
        OSError: the disk is full (ENOSPC) or the file would exceed the largest file this process
            may write (EFBIG, ``ulimit -f``); the message names ``path`` and the space needed.
    """
    try:
        try:
            if not hasattr(os, "posix_fallocate"):
                raise OSError(errno.EOPNOTSUPP, "no posix_fallocate")
            os.posix_fallocate(fd, 0, nbytes)
        except OSError as exc:
            if exc.errno not in (errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL):
                raise
            _write_zeros(fd, nbytes)
    except OSError as exc:
        if exc.errno == errno.EFBIG:
            raise OSError(exc.errno, f"could not write {str(path)!r}: it needs {_size(nbytes)}, more than the "
                                     "largest file this process may write (ulimit -f)") from exc
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise OSError(exc.errno, f"could not write {str(path)!r}: it needs {_size(nbytes)}, but its disk is "
                                     "full (or the user's quota reached)") from exc
        raise OSError(exc.errno, f"could not write {str(path)!r}: {exc.strerror or exc}") from exc


def _write_zeros(fd: int, nbytes: int) -> None:
    """Fill the file open as ``fd`` with zeros from its end up to ``nbytes`` bytes."""
    block = bytes(1 << 20)
    for offset in range(os.fstat(fd).st_size, nbytes, len(block)):
        write_at(fd, block[: min(len(block), nbytes - offset)], offset)


def write_at(fd: int, data, offset: int) -> None:
    """Write all of ``data`` (bytes-like) at ``offset`` in the file open as ``fd`` (ordinary writes:
    a full disk is an ``OSError``, never a signal)."""
    view = memoryview(data).cast("B")
    while len(view):
        if hasattr(os, "pwrite"):
            n = os.pwrite(fd, view, offset)
        else:
            os.lseek(fd, offset, os.SEEK_SET)
            n = os.write(fd, view)
        view, offset = view[n:], offset + n
