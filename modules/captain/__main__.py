"""`python -m modules.captain`: run the CAPTAIN module."""

import sys

from modules.captain.main import main

sys.exit(main())
