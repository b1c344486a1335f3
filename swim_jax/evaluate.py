"""``python -m swim_jax.evaluate``: evaluate trained policies in Gymnasium itself.

A door: the command's code and its documentation are in swim_jax/analysis/evaluate.py.
"""

import sys

from swim_jax.analysis.evaluate import main

if __name__ == "__main__":
    sys.exit(main())
