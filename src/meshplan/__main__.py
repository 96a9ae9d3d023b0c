"""``python -m meshplan``."""

import sys

from .cli import main

sys.exit(main())
