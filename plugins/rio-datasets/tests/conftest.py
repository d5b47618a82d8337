import pytest

from rio.recording.synthetic import record_synthetic


def pytest_configure(config):
    config.addinivalue_line("markers", "lerobot: loads an export with lerobot itself (skipped unless installed)")


@pytest.fixture(scope="session")
def native(tmp_path_factory):
    """Two short synthetic episodes: two cameras (one with depth), SingleArmObs, instructions."""
    root = tmp_path_factory.mktemp("native") / "ds"
    record_synthetic(str(root), episodes=2, steps=20, fps=30, video={"crf": 18})
    return root
