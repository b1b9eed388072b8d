"""3D preview of node outputs with viser (issue 8).

`ViewerService` (service.py) runs the viser server and GUI; `scene` adapts output values to scene
nodes under `/graph/<node>/<port>`; `geometry`, `colors` and `signature` are pure kernels (no
viser) that turn values into display arrays, colours and content signatures.
"""

from .service import ViewerService

__all__ = ["ViewerService"]
