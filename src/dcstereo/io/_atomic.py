"""Atomic writes: a temporary file beside each output, moved onto it when all is written.

The machinery behind :func:`dcstereo.io.atomic_write` and :func:`dcstereo.io.atomic_writes`
(re-exported there), and the leftovers of killed writers: a temporary file is named
``.<stem>.tmp<8 hex digits><suffix>`` beside ``<stem><suffix>``; while its writer lives it
holds an advisory lock on it (``flock``), which the system drops when the writer dies, so
:func:`remove_stale_temporaries` removes what killed writers left and never a live
writer's file. One level only: a writer handed a temporary file of an atomic write still
open in this process writes it directly.
"""

import os
import re
import secrets
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

try:  # the lock that tells a live temporary file from a killed writer's (POSIX)
    import fcntl
except ImportError:  # pragma: no cover - Windows: leftovers are told by their names alone
    fcntl = None


@contextmanager
def atomic_write(path: str | os.PathLike) -> Iterator[Path]:
    """Give a temporary path next to ``path`` and move it onto ``path`` on success.

    The temporary file is hidden (``.out.tmpXXXXXXXX.png`` for ``out.png``) and keeps the
    real suffix last, so writers that pick the format from the name (Pillow) still work.
    If the body raises, the temporary file is removed and the exception propagates, so
    nothing half-written ever appears at ``path`` and an existing file there is untouched.
    A ``path`` that is itself the temporary file of an atomic write still open in this
    process (a writer called by :func:`atomic_writes`' caller) is written directly: one
    level of temporary files, never one inside another. While it exists the temporary
    file is locked, so that :func:`remove_stale_temporaries` tells it from what a killed
    writer left.

    Parameters
    ----------
    path : str or os.PathLike
        Final location of the file; its directory must exist.

    Yields
    ------
    Path
        The temporary file to write (it exists, empty).

    Examples
    --------
    >>> with atomic_write("out.png") as tmp:  # doctest: +SKIP
    ...     Image.fromarray(pixels).save(tmp)
    """
    with atomic_writes() as stage:
        yield stage(path)


@contextmanager
def atomic_writes() -> Iterator[Callable[[str | os.PathLike], Path]]:
    """Write several files all or none: :func:`atomic_write` for a group of outputs.

    Yields ``stage(path)``, which returns a temporary file next to ``path`` (as
    :func:`atomic_write` does). When the block ends without an error every temporary
    file is moved onto its path, in the order staged; if the block raises, all of them
    are removed. If a move fails partway (a folder's permissions changed, a path became
    a directory), the files already moved are put back as they were: the earlier
    contents of each overwritten path, kept by a hard link (a copy where the file system
    has none; where neither can be made, that path keeps its new file) until the group is
    in place, and no file where there was none. Otherwise the paths hold the whole new
    group or the whole old one, and no temporary file is left behind (unless putting a
    file back fails as well: the hidden second name then stays). The error is a one-line
    ``ValueError`` naming the path.

    Examples
    --------
    >>> with atomic_writes() as stage:  # doctest: +SKIP
    ...     np.save(stage("a.npy"), a)
    ...     np.save(stage("b.npy"), b)
    """
    staged: list[tuple[_Temporary, Path, str | os.PathLike]] = []

    def stage(path: str | os.PathLike) -> Path:
        if _is_live_temporary(path):  # a writer inside an outer atomic write: one level
            return Path(path)
        check_writable(path)
        target = Path(path)
        staged.append((_create_temp(target, path), target, path))
        return staged[-1][0].path

    try:
        yield stage
    except BaseException:
        for tmp, _, _ in staged:
            tmp.discard()
        raise
    _move_all(staged)


def _move_all(staged: list[tuple["_Temporary", Path, str | os.PathLike]]) -> None:
    """Move each temporary file onto its target; undo the moves made if one fails."""
    # (target, a second name of what was there or None, whether anything was there)
    moved: list[tuple[Path, _Temporary | None, bool]] = []
    i = 0
    try:
        for i, (tmp, target, _) in enumerate(staged):
            existed = target.is_symlink() or target.exists()
            # the last move is never undone: no later one can fail
            backup = _keep_earlier(target) if existed and i < len(staged) - 1 else None
            try:
                os.replace(tmp.path, target)
            except BaseException:
                if backup is not None:
                    backup.discard()
                raise
            tmp.release()
            moved.append((target, backup, existed))
    except BaseException as exc:
        for tmp, _, _ in staged:
            tmp.discard()
        _put_back(moved)
        if isinstance(exc, OSError):
            raise ValueError(f"cannot write '{staged[i][2]}': {_reason(exc)}") from None
        raise
    for _, backup, _ in moved:
        if backup is not None:
            backup.discard()


def _keep_earlier(target: Path) -> "_Temporary | None":
    """Return a hidden second name for what is at ``target`` (a hard link, else a copy).

    None where there is nothing at ``target``, or no second name could be made: that
    output then cannot be put back if a later move of its group fails.
    """
    if not target.is_symlink() and not target.is_file():
        return None
    for _ in range(100):
        backup = _temporary_name(target, secrets.token_hex(4))
        try:
            if target.is_symlink():
                os.symlink(os.readlink(target), backup)
                return _Temporary(backup, None)
            os.link(target, backup)
            return _Temporary(backup, _lock_new(backup, os.O_RDONLY))
        except FileExistsError:
            continue
        except OSError:
            break
    if target.is_symlink():
        return None
    try:  # no hard links on this file system
        backup = _create_temp(target, target)
    except ValueError:
        return None
    try:
        shutil.copy2(target, backup.path)
    except OSError:
        backup.discard()
        return None
    return backup


def _put_back(moved: list[tuple[Path, "_Temporary | None", bool]]) -> None:
    """Undo the moves of :func:`_move_all` (best effort: an error here is not raised).

    A path that held nothing is emptied again; one whose earlier file has no second name
    keeps the new file.
    """
    for target, backup, existed in reversed(moved):
        try:
            if backup is not None:
                os.replace(backup.path, target)
            elif not existed:
                target.unlink(missing_ok=True)
        except OSError:
            pass
        finally:
            if backup is not None:
                backup.release()


def check_writable(path: str | os.PathLike, *, make_folders: bool = False) -> None:
    """Fail at once when :func:`atomic_write` could not write ``path``.

    For tools that run a long job before writing: a bad output path is then a one-line
    ``ValueError`` before the work, not after it. With ``make_folders`` a missing folder
    is fine when the nearest existing one above it is a folder the caller can write in.
    """
    target = Path(path)
    if target.is_dir():
        raise ValueError(f"cannot write '{path}': it is a directory")
    folder = target.parent
    if make_folders:
        while not folder.exists() and folder != folder.parent:
            folder = folder.parent
    if not folder.is_dir():
        if make_folders or folder.exists():
            raise ValueError(f"cannot write '{path}': '{folder}' is not a directory")
        raise ValueError(f"cannot write '{path}': directory '{folder}' does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write '{path}': permission denied in '{folder}'")


#: How many characters longer than its target's name the name of an :func:`atomic_write`
#: temporary file is: ``.<stem>.tmp<8 hex digits><suffix>`` beside ``<stem><suffix>``.
TEMPORARY_NAME_EXTRA = len("..tmp") + 8


def _temporary_name(target: Path, token: str) -> Path:
    return target.with_name(f".{target.stem}.tmp{token}{target.suffix}")


def stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Return the temporary files of :func:`atomic_write` for ``path`` still there, sorted.

    A writer killed before its rename leaves one behind: ``.<stem>.tmp<8 hex><suffix>``
    beside ``<stem><suffix>``, or, from earlier versions, whose writers nested one atomic
    write inside another (``dcstereo run``'s), a temporary file of such a temporary file
    (``..<stem>.tmp<8 hex>.tmp<8 hex><suffix>``: one dot and one token a level). Only
    names of exactly this scheme are returned, never another output; some may belong to
    a writer still running (:func:`remove_stale_temporaries` leaves those).
    """
    target = Path(path)
    return sorted(_temporaries_of([target]).get(target.name, []))


def remove_stale_temporaries(*paths: str | os.PathLike) -> list[Path]:
    """Remove what killed writers of ``paths`` left (:func:`stale_temporaries`); return it.

    A temporary file that a live writer holds (it keeps a lock on its temporary file
    until the rename, released by the system when the writer dies) is left alone, so two
    processes writing one path never remove each other's work. Each folder is listed
    once, however many of its files are given (a batch's or a sequence's outputs).
    """
    removed = []
    for tmp in sorted(t for found in _temporaries_of(map(Path, paths)).values() for t in found):
        if _is_live_temporary(tmp) or not _unused(tmp):
            continue
        tmp.unlink(missing_ok=True)
        removed.append(tmp)
    return removed


#: A name of the temporary scheme: the longest run of ``.tmp<8 hex>`` tokens, a suffix.
_TEMPORARY_NAME = re.compile(
    r"(?P<head>\..*?)(?P<tokens>(?:\.tmp[0-9a-f]{8})+)(?P<suffix>\.[^.]*)?"
)


def _targets_of(name: str) -> list[str]:
    """Return the names whose temporary files (nested or not) ``name`` could be.

    ``k`` levels add ``k`` dots in front and ``k`` tokens before the suffix; the target's
    own name may hold tokens too, so every ``k`` that fits is a candidate.
    """
    found = _TEMPORARY_NAME.fullmatch(name)
    if found is None:
        return []
    head, suffix = found["head"], found["suffix"] or ""
    tokens = found["tokens"].split(".tmp")[1:]
    return [
        head[k:] + "".join(f".tmp{t}" for t in tokens[: len(tokens) - k]) + suffix
        for k in range(1, len(tokens) + 1)
        if head.startswith("." * k) and head[k:]
    ]


def _temporaries_of(targets) -> dict[str, list[Path]]:
    """Map each target's name to the temporary files of it in its folder (one listing each)."""
    folders: dict[Path, set[str]] = {}
    for target in targets:
        folders.setdefault(target.parent, set()).add(target.name)
    found: dict[str, list[Path]] = {}
    for folder, names in folders.items():
        try:
            entries = [entry.name for entry in os.scandir(folder) if entry.name[:1] == "."]
        except OSError:  # a missing or unreadable folder holds none we could remove
            continue
        for entry in entries:
            for name in set(_targets_of(entry)) & names:
                found.setdefault(name, []).append(folder / entry)
    return found


class _Temporary:
    """A temporary file of an atomic write: its path, and the open file that locks it.

    While it exists it is registered as live in this process (writers handed its path
    write it directly) and its lock tells other processes that its writer is alive.
    """

    def __init__(self, path: Path, lock: int | None):
        self.path = path
        self._lock = lock
        _LIVE.add(os.path.abspath(path))

    def release(self) -> None:
        """Forget the file (moved onto its target, or removed): close the lock."""
        _LIVE.discard(os.path.abspath(self.path))
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def discard(self) -> None:
        """Remove the file, then release it."""
        self.path.unlink(missing_ok=True)
        self.release()


#: The temporary files of the atomic writes open in this process (absolute paths).
_LIVE: set[str] = set()


def _is_live_temporary(path: str | os.PathLike) -> bool:
    return os.path.abspath(path) in _LIVE


def _lock_new(path: Path, flags: int) -> int | None:
    """Open ``path`` and hold an exclusive lock on it: the descriptor, or None."""
    try:
        return _held(os.open(path, flags))
    except OSError:
        return None


def _held(fd: int) -> int | None:
    """Take an exclusive lock on the open file ``fd``; return it (None: closed, no locks)."""
    if fcntl is None:
        os.close(fd)
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # no locks on this file system (or a remover's, for a moment): by name
        pass
    return fd


def _unused(tmp: Path) -> bool:
    """Whether no live writer holds ``tmp`` (its lock is free); True where there are no locks."""
    if fcntl is None:
        return True
    try:
        fd = os.open(tmp, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:  # a link (a killed writer's second name of a link), unreadable: by name
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    except OSError:  # no locks on this file system: by name only
        return True
    finally:
        os.close(fd)
    return True


def _create_temp(target: Path, shown: str | os.PathLike) -> _Temporary:
    # O_EXCL so two writers never share a temp file; mode 0o666 lets the umask decide; the
    # descriptor stays open, holding the lock, until the file is moved or removed
    for _ in range(100):
        tmp = _temporary_name(target, secrets.token_hex(4))
        try:
            fd = os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        except FileExistsError:
            continue
        except OSError as exc:
            raise ValueError(f"cannot write '{shown}': {_reason(exc)}") from None
        return _Temporary(tmp, _held(fd))
    raise ValueError(f"cannot write '{shown}': no free temporary file name")


def _reason(exc: OSError) -> str:
    text = exc.strerror or str(exc)
    return text[:1].lower() + text[1:]
