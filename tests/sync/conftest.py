"""Make the sync tests' shared link helper (_links.py) importable."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
