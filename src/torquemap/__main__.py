"""``python -m torquemap``."""

import sys

from torquemap.cli.main import main

sys.exit(main())
