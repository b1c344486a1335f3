"""``python -m swim_jax.bench SUBCOMMAND``: the door of the benchmarks (their list: swim_jax/bench/__init__.py)."""

import sys

from swim_jax.bench import main

if __name__ == "__main__":
    sys.exit(main())
