"""``python -m swim_jax.published RUN_DIR ... [--at-step N]``: our runs next to published curves at the
same step (docs/PUBLISHED.md).

A door: the command's code and its documentation are in swim_jax/analysis/published.py.
"""

import sys

from swim_jax.analysis.published import main

if __name__ == "__main__":
    sys.exit(main())
