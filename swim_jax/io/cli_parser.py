"""The argument parser of the project's command lines: a usage error is one line, exit status 2."""

from __future__ import annotations

import argparse


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are ONE line on stderr,
    ``<prog>: error: <message> (see --help)``, with exit status 2 (argparse's own prints the usage
    block before it)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")
