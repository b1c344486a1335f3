"""``python -m swim_jax.compare A_DIR B_DIR --out DIR``: two sets of runs compared cell by cell (e.g.
float32 against bfloat16 products).

A door: the command's code and its documentation are in swim_jax/analysis/cell_pairs.py.
"""

import sys

from swim_jax.analysis.cell_pairs import main

if __name__ == "__main__":
    sys.exit(main())
