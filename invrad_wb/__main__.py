"""``python -m invrad_wb``: the command line (see :mod:`invrad_wb.cli`)."""
import sys

from .cli import main

sys.exit(main())
