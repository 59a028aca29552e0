"""``python -m ufmt.cli``: the ``ufmt`` command."""

import sys

from ufmt.cli import main

sys.exit(main())
