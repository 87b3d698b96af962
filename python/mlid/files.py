"""Files written whole or not at all: to a temporary name in the target's
folder, renamed onto it when complete, so a killed run leaves the previous
file intact."""

import contextlib
import os
import stat
import tempfile
from pathlib import Path

from .errors import InputError

# the reasons a file cannot be written, in mlid-batch's words (fortran/base/mlid_files.f90)
NOT_WRITABLE = "(its folder is missing or not writable)"
A_FOLDER = "(a folder of that name)"
FULL = "(the disk is full, a file size limit was reached, or the file went away)"
NOT_RENAMED = "(a folder of that name, or no permission)"
A_DECK = "(a deck this run reads)"
BROKEN_LINK = "(a link to nothing, or a loop of links)"
READ_ONLY = "(a file you may not write)"
#: what a path may be that is no regular file, in mlid_files' not_regular words
_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"))


def not_regular(path, what=None):
    """Refuse to replace what is there when it is no regular file (a FIFO
    or a device would become one) or a link that leads nowhere, in
    mlid-batch's words; nothing when path is a regular file or not there."""
    name = f"{what} {path}" if what else f"{path}"
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if os.path.islink(path):
            raise InputError(f"cannot write {name} {BROKEN_LINK}") from None
        return
    except OSError:                     # a loop of links (ELOOP), or no permission
        if os.path.islink(path):
            raise InputError(f"cannot write {name} {BROKEN_LINK}") from None
        return
    for test, kind in _KINDS:
        if test(mode):
            raise InputError(f"cannot write {name} ({kind}, not a regular file)")


def write_target(path):
    """Where a write to path goes: the file a link names (the link stays),
    else path (as mlid_files' write_target)."""
    path = Path(path)
    if path.is_symlink() and path.exists():
        return Path(os.path.realpath(path))
    return path


def read_only(path, what=None):
    """Refuse a file that is there and that this user may not write (a
    rename would replace it all the same), in mlid-batch's words."""
    if os.path.exists(path) and not os.access(path, os.W_OK):
        raise InputError(f"cannot write {f'{what} {path}' if what else path} {READ_ONLY}")


@contextlib.contextmanager
def atomic_open(path, mode="w"):
    """A file handle whose content replaces path (or the file a link at path
    names) only when the block ends without an exception; text in UTF-8,
    whatever the locale says."""
    path = Path(path)
    not_regular(path)
    read_only(path)
    target = write_target(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    except OSError:
        raise InputError(f"cannot write {path} {NOT_WRITABLE}") from None
    try:
        fh = os.fdopen(fd, mode) if "b" in mode else os.fdopen(fd, mode, encoding="utf-8",
                                                                   errors="surrogateescape")
        with contextlib.suppress(OSError):     # best effort: some file systems refuse it
            os.fchmod(fd, _new_file_mode())    # mkstemp's 0600 is for secrets, not reports
        try:
            yield fh                           # the caller's own errors go on as they are
        except BaseException:
            with contextlib.suppress(OSError):
                fh.close()
            raise
        try:                    # the flush or the close may be what meets a full disk
            fh.flush()
            os.fsync(fh.fileno())
            fh.close()
        except OSError:
            with contextlib.suppress(OSError):
                fh.close()
            raise InputError(f"cannot write {path} {FULL}") from None
        try:
            os.replace(tmp, target)
        except OSError:
            raise InputError(f"cannot write {path} {NOT_RENAMED}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _new_file_mode():
    """The mode open() gives a new file, 0666 less the umask: what
    mlid-batch's files get.  The umask is read from /proc (asking os.umask
    means setting it, which other threads would see), else asked."""
    try:
        with open("/proc/self/status") as fh:
            umask = next(int(line.split()[1], 8) for line in fh if line.startswith("Umask:"))
    except (OSError, StopIteration, ValueError, IndexError):
        umask = os.umask(0o022)
        os.umask(umask)
    return 0o666 & ~umask


def atomic_write_text(path, text):
    """text to path in UTF-8, whatever the locale says (as mlid-batch writes)."""
    data = text.encode("utf-8", "surrogateescape")
    with atomic_open(path, "wb") as fh:
        try:
            fh.write(data)
        except OSError:
            raise InputError(f"cannot write {path} {FULL}") from None


def atomic_savefig(fig, path, **kw):
    path = Path(path)
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format=path.suffix.lstrip(".") or "png", **kw)


def same_file(a, b):
    """One file: by device and inode when both exist (hard links too), else
    by name with links resolved (as the core's same_file)."""
    if os.path.exists(a) and os.path.exists(b):
        return os.path.samefile(a, b)
    try:
        return os.path.realpath(a) == os.path.realpath(b)
    except OSError:             # a relative name in a folder that is gone
        return str(a) == str(b)


def check_writable(path, what, decks=()):
    """One clear line, before any work starts, if path cannot be written: a
    folder, a name ending in / (a folder, Path would drop the /), a folder
    missing or not writable, or one of the decks the run reads."""
    if Path(path).is_dir():
        raise InputError(f"cannot write {what} {path} {A_FOLDER}")
    if str(path).endswith(os.sep):
        raise InputError(f"cannot write {what} {path} {NOT_WRITABLE}")
    not_regular(path, what)
    read_only(path, what)
    if any(same_file(path, d) for d in decks):
        raise InputError(f"cannot write {what} {path} {A_DECK}")
    folder = Path(path).parent
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".mlid-check.")
        os.close(fd)
        os.unlink(tmp)
    except OSError:
        raise InputError(f"cannot write {what} {path} {NOT_WRITABLE}") from None
