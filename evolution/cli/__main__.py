"""``python -m evolution.cli``: the ``revolve`` command."""

import sys

from evolution.cli.main import main

sys.exit(main())
