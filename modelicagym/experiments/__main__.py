"""``python -m modelicagym.experiments reproduce|report ...``"""

import sys

from modelicagym.experiments.cli import main

sys.exit(main())
