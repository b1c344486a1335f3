"""``python -m swim_jax.plots``: the paper's Figures 1 and 2 (the activations and their derivatives).

A door: the command's code and its documentation are in swim_jax/analysis/plots.py.
"""

import sys

from swim_jax.analysis.plots import main

if __name__ == "__main__":
    sys.exit(main())
