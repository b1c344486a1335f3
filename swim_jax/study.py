"""``python -m swim_jax.study``: a whole study (every cell of a grid of configs), resumable.

A door: the command's code and its documentation are in swim_jax/run/study.py.
"""

import sys

from swim_jax.run.study import main

if __name__ == "__main__":
    sys.exit(main())
