"""``python -m swim_jax.render``: render one episode of a trained policy.

A door: the command's code and its documentation are in swim_jax/run/render.py.
"""

import sys

from swim_jax.run.render import main

if __name__ == "__main__":
    sys.exit(main())
