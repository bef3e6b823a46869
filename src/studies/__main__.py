"""``python -m studies`` is the ``studies`` command."""

import sys

from .cli import main  # sets the BLAS thread count before numpy loads

sys.exit(main())
