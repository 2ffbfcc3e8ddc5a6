"""``python -m invrad_wb``: the command line (see :mod:`invrad_wb.cli`)."""
import sys

from invrad_wb.cli import main

sys.exit(main())
