"""``python -m swim_jax.train``: train TD3 on every seed of a config at once.

A door: the command's code and its documentation are in swim_jax/run/train.py.
"""

import sys

from swim_jax.run.train import main

if __name__ == "__main__":
    sys.exit(main())
