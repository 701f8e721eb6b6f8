"""``python -m bench.reference``: the front door, ``run.main``."""
import sys

from .run import main

sys.exit(main())
