"""``python -m ridsafe``: the ``ridsafe`` command without the console script."""

import sys

from ridsafe.tools.cli.entry_point import main

sys.exit(main())
