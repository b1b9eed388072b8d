"""3D preview of node outputs with viser (issue 8).

`ViewerService` (service.py) runs the viser server and GUI; `scene` and `simulation` adapt output
values to scene nodes under `/graph/<node>/<port>`; `geometry`, `colors`, `signature` and `robot`
are pure kernels (no viser) that turn values into display arrays, colours, content signatures and
the arm's pose along the trace; `screenshot` drives headless Chromium (tests, docs).
"""

from .service import ViewerService

__all__ = ["ViewerService"]
