"""Viewer test fixtures; value builders live in viewer_fixtures.py (a unique module name, so
they cannot clash with other folders' conftest modules)."""

import pytest


@pytest.fixture
def viewer():
    from waamflow.viewer import ViewerService

    v = ViewerService(port=0, shared=True).start()  # the default view on the server-wide scene
    yield v
    v.stop()
