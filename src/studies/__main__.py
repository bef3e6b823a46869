"""``python -m studies`` is the ``studies`` command."""

import sys

from .cli import main

sys.exit(main())
