"""`python -m modules.map_navigator`: run the MAP NAVIGATOR module."""

import sys

from modules.map_navigator.main import main

sys.exit(main())
