"""``python -m swim_jax.report``: the paper's Tables II/III and Figure 4 from run folders.

A door: the command's code and its documentation are in swim_jax/analysis/report.py.
"""

import sys

from swim_jax.analysis.report import main

if __name__ == "__main__":
    sys.exit(main())
