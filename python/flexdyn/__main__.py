"""`python -m flexdyn ...` is the `flexdyn` command."""

import sys

from .cli import main

sys.exit(main())
