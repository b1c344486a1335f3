"""Build hook (everything else is in pyproject.toml): ship the top-level ``configs/`` inside the package.

``configs/`` (run recipes and ``configs/studies/``) stays beside ``swim_jax/`` in the checkout, where
an editable install reads it; a built wheel (or an install from the sdist, which carries configs/ by
MANIFEST.in) has no checkout around it, so ``build_py`` copies the tree to ``swim_jax/_configs/``.
``swim_jax.config.locate_config_dir`` picks one of the two.
"""

import os
import shutil

from setuptools import setup
from setuptools.command.build_py import build_py

SOURCE = "configs"
TARGET = os.path.join("swim_jax", "_configs")
SHIPPED = (".yaml", ".md")


def _config_files() -> list[str]:
    """The files of configs/ to ship, relative to it (YAML recipes, studies, the README)."""
    return sorted(os.path.relpath(os.path.join(folder, f), SOURCE)
                  for folder, _dirs, files in os.walk(SOURCE) for f in files if f.endswith(SHIPPED))


class BuildPyWithConfigs(build_py):
    """``build_py`` that also copies configs/ to ``<build_lib>/swim_jax/_configs/`` (not for an
    editable install, which reads configs/ in place)."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        shutil.rmtree(os.path.join(self.build_lib, TARGET), ignore_errors=True)  # no file deleted from configs/ lingers
        for rel in _config_files():
            dst = os.path.join(self.build_lib, TARGET, rel)
            self.mkpath(os.path.dirname(dst))
            self.copy_file(os.path.join(SOURCE, rel), dst)

    def get_outputs(self, include_bytecode=True):
        shipped = [] if getattr(self, "editable_mode", False) else [
            os.path.join(self.build_lib, TARGET, rel) for rel in _config_files()]
        return super().get_outputs(include_bytecode) + shipped


setup(cmdclass={"build_py": BuildPyWithConfigs})
