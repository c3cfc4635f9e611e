"""Runs the Blender tests inside real Blender:
    blender -b --factory-startup --python tests/blender/run.py -- [pytest arguments]
--factory-startup ignores the user's preferences, so conftest.py enables the addon itself."""
import os
import sys

import pytest

here = os.path.dirname(os.path.abspath(__file__))
args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
code = pytest.main(["-p", "no:cacheprovider", "-q", here] + args)
sys.stdout.flush()
os._exit(int(code))  # leave Blender at once with pytest's status
