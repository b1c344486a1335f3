"""The argument parser of the project's command lines: a usage error is one line, exit status 2."""

from __future__ import annotations

import argparse
import os
from typing import Mapping


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are ONE line on stderr,
    ``<prog>: error: <message> (see --help)``, with exit status 2 (argparse's own prints the usage
    block before it)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def output_file_problem(flag: str, path: str, force: bool | None = None) -> str | None:
    """Why ``path`` cannot be written as the file of option ``flag``, as one line, or None if it can.

    A file there is refused: ``exists; nothing written`` for a command without ``--force``
    (``force=None``), ``exists; refusing to overwrite (use --force)`` when ``--force`` was not given
    (``force=False``), and allowed with ``force=True``. A folder that does not exist is refused always:
    nothing creates it behind the user's back."""
    if os.path.exists(path) and not force:
        return f"{flag} {path} exists; " + ("nothing written" if force is None else
                                            "refusing to overwrite (use --force)")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        return f"{flag} {path}: folder {folder} does not exist"
    return None


def dotted_keys(tree: Mapping, prefix: str = "") -> dict:
    """A nested mapping flattened to its leaves by dotted path, the names a command-line override
    uses: ``{"agent": {"tau": 0.005}}`` → ``{"agent.tau": 0.005}``. A leaf is any value that is not a
    mapping (a list stays one leaf); keys keep their order."""
    out = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            out.update(dotted_keys(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def counted(n: int, noun: str) -> str:
    """``n`` and ``noun`` as command output and figure legends write a count: ``1 seed``, ``5 seeds``
    (a plural in ``s``)."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def one_line(e: BaseException, limit: int = 300) -> str:
    """An exception as one line of an error message: its text (or its type's name when it has none)
    with every run of whitespace made one space, cut at ``limit`` characters."""
    s = str(e) or type(e).__name__
    return " ".join(s.split())[:limit]
