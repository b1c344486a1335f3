"""``python -m swim_jax.evaluate``: evaluate trained policies in Gymnasium itself.

A door: the command's code and its documentation are in swim_jax/analysis/evaluate.py (our side of
``--ours-episodes`` in swim_jax/run/our_evaluation.py; both joined in swim_jax/run/evaluate.py).
"""

import sys

from swim_jax.run.evaluate import main

if __name__ == "__main__":
    sys.exit(main())
