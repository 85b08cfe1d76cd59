"""``python -m uavsnn`` runs the command line."""

import sys

from uavsnn.cli import main

sys.exit(main())
