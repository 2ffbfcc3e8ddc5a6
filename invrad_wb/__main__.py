"""``python -m invrad_wb``: the command line (see :mod:`invrad_wb.cli`)."""
import sys

from invrad_wb.runguard import stop_early_on_signals

stop_early_on_signals()         # SIGTERM while the modules load: one line, no traceback

from invrad_wb.cli import main  # noqa: E402
from invrad_wb.cli.common import leave  # noqa: E402

leave(main())       # hooks run, streams flushed, no slow interpreter finalisation
