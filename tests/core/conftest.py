import sys
from pathlib import Path
import pytest
sys.path.insert(0, str(Path(__file__).parents[1]))
import fmu_factory

class _Lazy(dict):
    def __init__(self, root): super().__init__(); self.root = root
    def __missing__(self, key):
        p = fmu_factory.build_by_key(key, self.root); self[key] = p; return p

@pytest.fixture(scope="session")
def test_fmus(tmp_path_factory):
    return _Lazy(tmp_path_factory.mktemp("fmus"))
