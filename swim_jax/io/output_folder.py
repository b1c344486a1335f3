"""An output folder written all or nothing: the one rule of ``--out DIR`` for the commands that
write a set of files (``python -m swim_jax.report``, ``swim_jax.compare``, ``swim_jax.study --report``).

A command owns a fixed set of file names (``owned``: all it may ever write there). ``DIR`` must be a
new path or an empty folder; with ``force`` it may be a folder holding anything: then the owned
files are replaced, those of them this call does not write (a figure an earlier call drew) are
removed, and every other file stays. Everything is written into a temporary folder first; a new
``DIR`` is that folder renamed into place; in an existing one the old owned files are moved aside,
the new ones moved in, and on any failure the old ones are put back. A refusal or failure is an
:class:`OutputFolderError` of one line, and nothing in ``DIR`` has changed.
"""

from __future__ import annotations

import os
import shutil
import tempfile


class OutputFolderError(ValueError):
    """``--out`` cannot receive the files (one line naming the folder, what is wrong and what is valid)."""


def check(out: str, force: bool, owned: tuple[str, ...]) -> None:
    """Raise :class:`OutputFolderError` unless ``out`` can receive the files: a path to create, an
    empty folder, or (``force``) a folder whose ``owned`` entries are plain files or symbolic links."""
    if not out.strip():
        raise OutputFolderError("--out is empty; give the output folder (a new path, an empty folder, or, "
                                "with --force, a folder written before)")
    if os.path.islink(out) and not os.path.exists(out):
        raise OutputFolderError(f"--out {out} is a dangling symbolic link (to {os.readlink(out)}); give a new "
                                f"path, an existing folder, or a link to one")
    if not os.path.exists(out):
        return
    if not os.path.isdir(out):
        raise OutputFolderError(f"--out {out} exists and is not a directory; give a new path or a folder")
    try:
        entries = os.listdir(out)
    except OSError as e:
        raise OutputFolderError(f"--out {out}: cannot read the folder ({os_error(e)})") from None
    if entries and not force:
        raise OutputFolderError(f"--out {out} exists and is not empty; refusing to overwrite (use --force "
                                f"to replace {', '.join(owned)} there; other files stay)")
    for name in owned:
        p = os.path.join(out, name)
        if os.path.lexists(p) and not (os.path.islink(p) or os.path.isfile(p)):
            kind = "a directory" if os.path.isdir(p) else "not a regular file"
            raise OutputFolderError(f"--out {out}: {p} is {kind}; --force replaces only files named "
                                    f"{', '.join(owned)} (move it away or choose another --out)")


def write(out: str, files: dict[str, str | bytes], force: bool, owned: tuple[str, ...]) -> None:
    """Write ``files`` (name -> text or bytes; every name one of ``owned``) into ``out``, all or
    nothing (see the module docstring); with ``force``, the ``owned`` files not in ``files`` are
    removed from ``out``. Raises :class:`OutputFolderError`."""
    stray = sorted(set(files) - set(owned))
    if stray:
        raise ValueError(f"files {stray} are not among the owned names {owned}")
    check(out, force, owned)
    exists = os.path.isdir(out)
    try:
        if exists:  # a temporary folder inside out: the renames stay on out's file system
            tmp = tempfile.mkdtemp(prefix=".out-", dir=out)
        else:
            parent = os.path.dirname(os.path.abspath(out))
            os.makedirs(parent, exist_ok=True)
            tmp = tempfile.mkdtemp(prefix=".out-", dir=parent)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o777 & ~umask)
    except OSError as e:
        raise OutputFolderError(f"--out {out}: cannot write ({os_error(e)})") from None
    try:
        for name, content in files.items():
            mode = "wb" if isinstance(content, bytes) else "w"
            with open(os.path.join(tmp, name), mode, **({} if mode == "wb" else {"encoding": "utf-8"})) as f:
                f.write(content)
        if not exists:
            os.rename(tmp, out)
            tmp = None
        else:
            _swap_in(out, tmp, owned, list(files))
    except OSError as e:
        raise OutputFolderError(f"--out {out}: cannot write ({os_error(e)}); nothing was "
                                f"changed there") from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def _swap_in(out: str, tmp: str, owned: tuple[str, ...], names: list[str]) -> None:
    """Move every existing ``owned`` entry of ``out`` aside into ``tmp``, then the new ``names``
    from ``tmp`` into ``out``; on an OSError undo both steps and re-raise."""
    aside = os.path.join(tmp, ".previous")
    os.mkdir(aside)
    moved, placed = [], []
    try:
        for name in owned:
            if os.path.lexists(os.path.join(out, name)):
                os.replace(os.path.join(out, name), os.path.join(aside, name))
                moved.append(name)
        for name in names:
            os.replace(os.path.join(tmp, name), os.path.join(out, name))
            placed.append(name)
    except OSError:
        for name in placed:
            try:
                os.remove(os.path.join(out, name))
            except OSError:
                pass
        for name in moved:
            try:
                os.replace(os.path.join(aside, name), os.path.join(out, name))
            except OSError:
                pass
        raise


def os_error(e: OSError) -> str:
    """``strerror: path`` of an OSError, on one line."""
    msg = e.strerror or str(e) or type(e).__name__
    if e.filename:
        msg += f": {e.filename}"
    return " ".join(msg.split())[:300]
