"""Make the sync tests' shared link helper (_links.py) importable."""

import sys
from pathlib import Path

sys.path.append(str(Path(__file__).parent))  # appended: tests/conftest.py must keep the name "conftest"
