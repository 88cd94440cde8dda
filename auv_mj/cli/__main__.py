"""`python -m auv_mj.cli ...` is the `auv-mj` command."""

import sys

from auv_mj.cli import main

sys.exit(main())
