"""``python -m modelicagym.experiments reproduce|report ...``"""

import sys

from modelicagym.experiments.cli import main

if __name__ == "__main__":  # the pool's worker processes import this module too
    sys.exit(main())
